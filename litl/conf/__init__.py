"""Hydra configuration of `python -m litl`: the schema (`schema.py`) and the config groups (YAML).

The top-level `conf/` of the repository points here, so the configs ship inside the package and
are found from editable and non-editable installs alike.
"""
