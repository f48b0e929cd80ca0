"""The `rt` command line: validate, render and describe scene files."""
