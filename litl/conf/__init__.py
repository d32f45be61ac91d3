"""Hydra configuration of `python -m litl`: the config groups (YAML); the schema
and every default is `litl.config.Config`.

The top-level `conf/` of the repository points here, so the configs ship inside the package and
are found from editable and non-editable installs alike.
"""
