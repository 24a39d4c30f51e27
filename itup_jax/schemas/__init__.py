"""JSON Schemas of the documents the CLI and experiments write (see README.md here)."""

from __future__ import annotations

import importlib.resources
import json
import pathlib

#: The schemas' folder, inside the installed package.
SCHEMA_DIR = pathlib.Path(str(importlib.resources.files("itup_jax.schemas")))


def load_schema(name: str) -> dict:
    """The schema 'plan' | 'evaluate' | 'demo' | 'table1' as a dict."""
    path = SCHEMA_DIR / f"{name}.schema.json"
    if not path.exists():
        from itup_jax.errors import InputError

        raise InputError(f"load_schema: no schema {name!r}; have {sorted(p.name.split('.')[0] for p in SCHEMA_DIR.glob('*.schema.json'))}")
    return json.loads(path.read_text())
