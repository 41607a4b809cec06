"""``python -m mjregen``: the `mjregen` command."""

import sys

from mjregen.cli import main

sys.exit(main())
