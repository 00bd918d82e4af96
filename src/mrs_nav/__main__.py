"""``python -m mrs_nav`` runs the ``mrs-nav`` command."""

import sys

from mrs_nav.cli.main import main

sys.exit(main())
