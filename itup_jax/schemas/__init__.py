"""JSON Schemas of the documents the CLI and experiments write (see README.md here)."""

from __future__ import annotations

import json
import pathlib

SCHEMA_DIR = pathlib.Path(__file__).resolve().parent


def load_schema(name: str) -> dict:
    """The schema 'plan' | 'evaluate' | 'demo' | 'table1' as a dict."""
    path = SCHEMA_DIR / f"{name}.schema.json"
    if not path.exists():
        from itup_jax.errors import InputError

        raise InputError(f"load_schema: no schema {name!r}; have {sorted(p.name.split('.')[0] for p in SCHEMA_DIR.glob('*.schema.json'))}")
    return json.loads(path.read_text())
