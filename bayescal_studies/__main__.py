"""``python -m bayescal_studies``: the research commands (:mod:`bayescal_studies.cli`)."""

import sys

from bayescal_studies.cli import main

sys.exit(main())
