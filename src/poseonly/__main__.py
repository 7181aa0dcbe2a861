"""``python -m poseonly``: the ``poseonly`` command."""

from .cli import main

if __name__ == "__main__":
    raise SystemExit(main())
