"""``python -m uavplan`` runs the command line."""

from uavplan.cli import main

main()
