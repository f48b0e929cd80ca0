"""`python -m scenefmt.docgen`: regenerate `docs/format.md` (or, with `--check`, say whether it is stale)."""

from . import main

raise SystemExit(main())
