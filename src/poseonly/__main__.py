"""``python -m poseonly``: the ``poseonly`` command."""

from .cli import main

raise SystemExit(main())
