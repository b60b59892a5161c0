"""`python -m sideslip.cli`."""

from sideslip.cli import main

main()
