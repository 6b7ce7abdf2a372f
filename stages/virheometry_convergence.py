"""virheometry_convergence: a material's dam breaks simulated with its laws on a sequence of grids and time steps;
the observed order and the extrapolated limit of the loss and the flow, the time step's effect and which law wins at
each resolution (JSON and a page). Every simulation is stored, so an interrupted study resumes."""

from pathlib import Path

from rheo.experiments.virheometry import read_setup
from rheo.fit.convergence import (
    EvaluationStore,
    default_cells,
    engine_fingerprint,
    rheometer_law,
    run,
    study_cases,
    summarize,
)
from rheo.io import evaluations_path, write_json_atomic, write_text_atomic
from rheo.report.convergence import render
from rheo.stage import start_stage

smk = snakemake  # noqa: F821  (injected by Snakemake)
log = start_stage(smk)
study, simulation, material = smk.params.study, smk.params.simulation, smk.wildcards.material
laws = {label: tuple(law) for label, law in smk.params.laws.items()}
if smk.input.rheometer:
    laws["rheometer"] = rheometer_law(list(smk.input.rheometer), tuple(study["rheometer_band"]))
log.info("laws: %s", laws)
setups = [read_setup(f, smk.params.scale, smk.params.fps) for f in smk.params.folders]
cases = study_cases(setups, laws, study["grids"], study["cfls"],
                    (simulation["cells_per_height"], simulation["cells_across"]))
output = Path(smk.output.summary)
store = EvaluationStore(evaluations_path(output), engine_fingerprint())
rows = run(cases, simulation, smk.params.scale, store, smk.threads)
default_h = default_cells(setups, simulation)
result = {"material": material, "laws": laws, "study": study, "simulation": simulation, "engine": store.fingerprint,
          "default_h_m": default_h, "rows": rows, **summarize(rows, default_h)}
write_json_atomic(output, result)
write_text_atomic(smk.output.report, render(result))
