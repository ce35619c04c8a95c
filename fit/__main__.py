"""``python -m trispline.fit``: the trispline command line (see :mod:`trispline.fit.cli`)."""
from trispline.fit.cli import main

raise SystemExit(main())
