"""The scene JSON Schema, generated from the models by `python -m scenefmt.schema_export` and
shipped inside the installed package as `scenefmt.schemas`."""
