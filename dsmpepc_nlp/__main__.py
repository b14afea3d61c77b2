"""``python -m dsmpepc_nlp``: the command line (same as ``dsmpepc``)."""

from .cli import main

raise SystemExit(main())
