"""``frictionid validate SOURCE --params OUT.json [--json V.json]``: cross-test identified parameters."""

from __future__ import annotations

import argparse
from pathlib import Path

from frictionid_core.cli._common import add_source_arguments, load_source, print_metrics, save_json


def add_arguments(p: argparse.ArgumentParser) -> None:
    add_source_arguments(p)
    p.add_argument("--params", type=Path, required=True, help="JSON written by 'frictionid identify'")


def run(args) -> int:
    from frictionid_core.identification import validate
    from frictionid_core.jsonfile import read_json

    params = read_json(args.params, "parameters")
    series = load_source(args)
    metrics = validate(series, params)
    out = {"source": series.source, "params_file": str(args.params), "system": params.get("system"),
           "friction": params.get("friction"), "asymmetric": params.get("asymmetric"), "metrics": metrics}
    print(f"cross-test of {args.params} on {series.source}")
    print_metrics(metrics)
    save_json(args.json, out)
    return 0
