"""SARIF 2.1.0: the schema committed in tests/data/, and a reader that validates against it."""
from __future__ import annotations

import json
import os

import jsonschema

SCHEMA_PATH = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "data",
                           "sarif-schema-2.1.0.json")


def sarif_schema() -> dict:
    with open(SCHEMA_PATH, encoding="utf-8") as f:
        return json.load(f)


def validate_sarif(text: str) -> dict:
    doc = json.loads(text)
    jsonschema.Draft7Validator(sarif_schema()).validate(doc)
    return doc
