"""Collect the column-collapse runs into collapse.csv and collapse.html (thesis Tables 4.1, 4.2, Figs 4.2, 4.4)."""


from rheo.io import read_json, write_text_atomic
from rheo.report.collapse import render, rows_from_runs, to_csv
from rheo.stage import start_stage

smk = snakemake  # noqa: F821  (injected by Snakemake)
log = start_stage(smk)
calibration = read_json(smk.input.calibration)
runs_41 = [r for r in (read_json(p) for p in smk.input.calibration_runs)
           if (r["mu"], r["lam"]) == (calibration["mu"], calibration["lam"])]
runs_42 = [read_json(p) for p in smk.input.predictions]
table_41 = rows_from_runs("4.1", runs_41, {float(k): v for k, v in smk.params.rows_41.items()},
                          key=lambda r: r["sigma_y"])
table_42 = rows_from_runs("4.2", runs_42, {float(k): v for k, v in smk.params.rows_42.items()},
                          key=lambda r: round(r["eta"] / r["sigma_y"], 12))
for row in table_41 + table_42:
    log.info("Table %s sigma_y=%g eta=%g: thesis %.5f, rheo %.5f (%+.1f %%)", row["table"], row["sigma_y"],
             row["eta"], row["thesis_height"], row["rheo_height"], 100 * row["relative_difference"])
write_text_atomic(smk.output.csv, to_csv(table_41 + table_42))
write_text_atomic(smk.output.html, render(table_41, table_42, calibration))
