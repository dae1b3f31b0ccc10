"""Build the installable QGIS plugin: dist/lidar_sig_provider.zip, for QGIS's Plugins > Manage and
Install Plugins > Install from ZIP (docs/qgis.md).

    python qgis/build_plugin.py [--output dist/lidar_sig_provider.zip]

The zip holds the folder lidar_sig_provider/ (without caches), the project's LICENSE, and
metadata.txt with the version of the package (pyproject.toml), so that the plugin and the
command it runs carry one version. Standard library only: runs with any Python 3.
"""
import argparse
import re
import sys
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PLUGIN = ROOT / "qgis" / "lidar_sig_provider"


def version():
    """The package's version, from pyproject.toml."""
    found = re.search(r'^version\s*=\s*"([^"]+)"', (ROOT / "pyproject.toml").read_text(encoding="utf-8"), re.M)
    if not found:
        sys.exit("build_plugin: pyproject.toml has no version")
    return found[1]


def build(output):
    """Write the zip ``output`` (through a temporary file beside it: a failed build leaves none)."""
    output = Path(output)
    output.parent.mkdir(parents=True, exist_ok=True)
    tmp = output.with_name(f".{output.name}.tmp")
    metadata = re.sub(r"^version=.*$", f"version={version()}", (PLUGIN / "metadata.txt").read_text(encoding="utf-8"),
                      flags=re.M)
    try:
        with zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as z:
            for path in sorted(PLUGIN.rglob("*")):
                if path.is_dir() or "__pycache__" in path.parts or path.suffix == ".pyc":
                    continue
                name = f"{PLUGIN.name}/{path.relative_to(PLUGIN).as_posix()}"
                if path.name == "metadata.txt":
                    z.writestr(name, metadata)
                else:
                    z.write(path, name)
            z.write(ROOT / "LICENSE", f"{PLUGIN.name}/LICENSE")
        tmp.replace(output)
    finally:
        tmp.unlink(missing_ok=True)
    return output


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--output", default=str(ROOT / "dist" / "lidar_sig_provider.zip"),
                        help="the zip to write [default: dist/lidar_sig_provider.zip]")
    args = parser.parse_args(argv)
    print(f"wrote {build(args.output)}")


if __name__ == "__main__":
    main()
