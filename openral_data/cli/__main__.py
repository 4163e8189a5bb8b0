"""`python -m openral_data.cli` runs the command line."""

from openral_data.cli import main

main()
