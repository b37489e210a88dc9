"""`python -m mechnet` runs the same command as the `mechnet` console script."""
import sys

from mechnet.cli import main

sys.exit(main())
