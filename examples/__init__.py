"""twoscale's examples, a package so that its scripts import each other plainly.

Run them as modules from the repository's root, e.g. `.venv/bin/python -m examples.fit.compare --help`.
"""
