"""`lidar-sig sample`: the embedded sample's files written into a folder."""
import json

import click

from .options import json_option, overwrite_option
from .summaries import say


@click.command()
@click.argument("folder")
@overwrite_option
@json_option
def sample(folder, overwrite, as_json):
    """Write the embedded sample, a synthetic two-epoch urban scene, into FOLDER: epoch1.laz,
    epoch2.laz (turned by 20 degrees) and epoch2_aligned.laz (epoch 2 on epoch 1's ground).

    The files are the same on every machine; one already in FOLDER with the same bytes is left
    as it is. The README's first command then runs from an installed package as from a clone.
    """
    from ..data import write_sample

    files = write_sample(folder, overwrite=overwrite)
    if as_json:
        click.echo(json.dumps({"files": [{"path": str(f.path), "points": f.points, "written": f.written}
                                         for f in files]}))
        return
    for f in files:
        say(f"{'wrote' if f.written else 'kept'} {f.path} ({f.points:,} points"
            + ("" if f.written else ", already there and the same") + ")")
