#!/usr/bin/env python3
"""Validates an export's manifest.json against the JSON Schema it ships with
(manifest.schema.json), with the reference validator (python-jsonschema, draft
2020-12: every keyword, `pattern` included). Usage: validate_manifest.py EXPORT_DIR."""
import json
import os
import sys

import jsonschema

d = sys.argv[1]
with open(os.path.join(d, "manifest.schema.json")) as f:
    schema = json.load(f)
with open(os.path.join(d, "manifest.json")) as f:
    manifest = json.load(f)
jsonschema.Draft202012Validator.check_schema(schema)
errors = sorted(jsonschema.Draft202012Validator(schema).iter_errors(manifest), key=str)
for e in errors[:10]:
    print(f"{'/'.join(map(str, e.absolute_path))}: {e.message}")
print(f"{d}/manifest.json: {len(errors)} schema violations")
sys.exit(1 if errors else 0)
