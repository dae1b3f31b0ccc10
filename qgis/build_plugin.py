"""Build the installable QGIS plugin: dist/lidar_sig_provider.zip, for QGIS's Plugins > Manage and
Install Plugins > Install from ZIP (docs/qgis.md).

    python qgis/build_plugin.py [--output dist/lidar_sig_provider.zip]

The zip holds the folder lidar_sig_provider/ (without caches, with its icons), the project's
LICENSE, metadata.txt with the version of the package (pyproject.toml), so that the plugin and
the command it runs carry one version, and help/JOB.html, each command's page
(docs/commands/JOB.md) as HTML, which an algorithm's Help button opens. Standard library only:
runs with any Python 3.
"""
import argparse
import html
import re
import sys
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PLUGIN = ROOT / "qgis" / "lidar_sig_provider"
COMMANDS = ROOT / "docs" / "commands"
#: Inline Markdown of the docs: `code`, **bold**, [text](target).
INLINE = re.compile(r"`([^`]+)`|\*\*(.+?)\*\*|\[([^\]]+)\]\(([^)\s]+)\)")


def version():
    """The package's version, from pyproject.toml."""
    found = re.search(r'^version\s*=\s*"([^"]+)"', (ROOT / "pyproject.toml").read_text(encoding="utf-8"), re.M)
    if not found:
        sys.exit("build_plugin: pyproject.toml has no version")
    return found[1]


def inline(text, pages):
    """One line of Markdown as HTML: code, bold, and links; a link to another command's page
    leads to its HTML copy, any other link to the docs keeps only its text (the rest of the
    docs is not in the plugin)."""
    out, at = [], 0
    for found in INLINE.finditer(text):
        out.append(html.escape(text[at:found.start()]))
        code, bold, label, target = found.groups()
        if code is not None:
            out.append(f"<code>{html.escape(code)}</code>")
        elif bold is not None:
            out.append(f"<strong>{inline(bold, pages)}</strong>")
        else:
            page, _, anchor = target.partition("#")
            shown = inline(label, pages)
            if target.startswith(("http://", "https://")):
                out.append(f'<a href="{html.escape(target)}">{shown}</a>')
            elif page.endswith(".md") and "/" not in page and page[:-3] in pages:
                out.append(f'<a href="{page[:-3]}.html{"#" + anchor if anchor else ""}">{shown}</a>')
            else:
                out.append(shown)
        at = found.end()
    return "".join(out) + html.escape(text[at:])


def help_page(markdown, pages):
    """A command's page of the docs (Markdown: headings, paragraphs, lists, fenced code) as one
    HTML page."""
    body, block, kind = [], [], None

    def close():
        nonlocal block, kind
        if kind == "pre":
            body.append("<pre><code>" + "\n".join(html.escape(line) for line in block) + "</code></pre>")
        elif kind == "p":
            body.append("<p>" + inline(" ".join(block), pages) + "</p>")
        elif kind == "ul":
            body.append("<ul>" + "".join(f"<li>{inline(item, pages)}</li>" for item in block) + "</ul>")
        block, kind = [], None

    for line in markdown.splitlines():
        if line.startswith("```"):
            opening = kind != "pre"
            close()
            kind = "pre" if opening else None
        elif kind == "pre":
            block.append(line)
        elif not line.strip():
            close()
        elif re.match(r"#{1,6} ", line):
            close()
            level = len(line) - len(line.lstrip("#"))
            body.append(f"<h{level}>{inline(line[level:].strip(), pages)}</h{level}>")
        elif line.startswith("- "):
            if kind != "ul":
                close()
                kind = "ul"
            block.append(line[2:])
        elif kind == "ul" and line.startswith("  "):
            block[-1] += " " + line.strip()
        else:
            if kind != "p":
                close()
                kind = "p"
            block.append(line.strip())
    close()
    title = re.sub(r"<[^>]+>", "", body[0]) if body and body[0].startswith("<h1>") else "lidar-sig"
    return ('<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8"><title>' + title + "</title><style>"
            "body{font-family:sans-serif;max-width:60em;margin:1em auto;padding:0 1em;line-height:1.45}"
            "pre{background:#f4f4f4;padding:.6em;overflow-x:auto}code{font-size:.92em}</style></head><body>\n"
            + "\n".join(body) + "\n</body></html>\n")


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
            pages = {path.stem for path in COMMANDS.glob("*.md")}
            for page in sorted(pages):
                text = (COMMANDS / f"{page}.md").read_text(encoding="utf-8")
                z.writestr(f"{PLUGIN.name}/help/{page}.html", help_page(text, pages))
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
