"""The lab: this project's experiments, readings and reports, a client of the ``antmaze_hirl`` package.

It imports the package; the package never imports it. It is not shipped in the wheel
(``pyproject.toml`` finds ``antmaze_hirl*`` only) and sets no library default. Run its modules from the
repository root, e.g. ``python -m antmaze_lab.preregistered``.
"""
