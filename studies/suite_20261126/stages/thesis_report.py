"""The thesis report: recovery Tables 4.3-4.5 from the fits of cup, squirt and squirt_small beside the thesis'
numbers, and the forward Tables 4.1 and 4.2 from collapse.csv."""

import csv

from rheo.io import read_json, write_text_atomic
from rheo.report.thesis import recovery_rows, render
from rheo.stage import start_stage

smk = snakemake  # noqa: F821  (injected by Snakemake)
log = start_stage(smk)
tables = []
for (key, spec), path in zip(smk.params.tables.items(), smk.input.params, strict=True):
    rows = recovery_rows(spec["recovered"], read_json(path))
    name = key.removeprefix("table_").replace("_", ".")
    tables.append((name, spec["title"], rows))
    for r in rows:
        log.info("Table %s %s: truth %.4g, thesis %.4g, rheo %.4g (%s)", name, r["parameter"], r["truth"],
                 r["thesis"], r["rheo"], "held at the guess" if r["held"] else f"error {r['rheo_error']:.1%}")
with open(smk.input.collapse) as f:
    collapse = list(csv.DictReader(f))
write_text_atomic(smk.output[0], render(tables, collapse))
