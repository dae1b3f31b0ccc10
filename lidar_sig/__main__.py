"""``python -m lidar_sig`` runs the command line."""
from .cli import main

main()
