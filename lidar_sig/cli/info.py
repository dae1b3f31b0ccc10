"""`lidar-sig info`: what a signature archive, a survey catalogue or a point-cloud file holds."""
import click

from .options import columns_option, json_option
from .summaries import show


@click.command()
@click.argument("path")
@columns_option
@json_option
def info(path, columns, as_json):
    """Summarize a signature archive or survey catalogue (.h5), or a point-cloud file."""
    from ..jobs import info as info_job

    show(info_job(path, columns=columns), as_json=as_json)
