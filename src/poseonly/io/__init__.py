"""Loaders for external datasets (e.g. :mod:`poseonly.io.strecha`)."""
