"""numpy reference implementations: the oracles the core (``poseonly._core``) is tested against."""
