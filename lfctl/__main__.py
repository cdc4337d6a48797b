"""`python -m lfctl` is the `lfctl` command."""

import sys

from lfctl.cli import main

sys.exit(main())
