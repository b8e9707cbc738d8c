#!/usr/bin/python3
"""Validates summary.json files against docs/summary.schema.json, or cohort-summary.json
files against docs/cohort-summary.schema.json (issue 22, item 9).

Usage: check_summary_schema.py SCHEMA SUMMARY.json [SUMMARY.json ...]
Exit 0 when every file is valid, 1 with one line per error otherwise, 3 when the jsonschema
module is missing (scripts/install-deps.sh installs python3-jsonschema)."""
import json
import sys

try:
    import jsonschema
except ImportError:
    print("FRONTMESH-TEST-SKIPPED: python3-jsonschema is not installed")
    sys.exit(3)


def main():
    if len(sys.argv) < 3:
        print(__doc__)
        return 2
    with open(sys.argv[1]) as f:
        schema = json.load(f)
    validator_class = jsonschema.validators.validator_for(schema)
    validator_class.check_schema(schema)
    validator = validator_class(schema, format_checker=jsonschema.FormatChecker())
    bad = 0
    for path in sys.argv[2:]:
        with open(path) as f:
            summary = json.load(f)
        errors = sorted(validator.iter_errors(summary), key=lambda e: list(e.path))
        for e in errors:
            where = "/".join(str(p) for p in e.path) or "(top)"
            print(f"{path}: {where}: {e.message[:300]}")
        bad += bool(errors)
        if not errors:
            print(f"{path}: valid")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
