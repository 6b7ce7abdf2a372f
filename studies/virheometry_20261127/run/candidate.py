"""One candidate's profile of a diagnosis, under the diagnosis' own evaluation key, into its own evaluation log
(merged with the others' afterwards: the log is indexed by phase and point, each candidate has its own phase),
which starts from the diagnosis' stored evaluations where there are any."""
import json
import shutil
from pathlib import Path

import numpy as np
import tolerant  # noqa: F401  (replays points within its tolerance of stored ones)

from rheo.diagnose.dam_break import diagnose
from rheo.fit.dam_break import RESULT_KEYS, setup_files
from rheo.fit.search import EvaluationLog
from rheo.io import read_json
from rheo.stage import inputs_key, start_stage

smk = snakemake  # noqa: F821
log = start_stage(smk)
setups = setup_files(smk.input.setups, smk.input.masks)
fit = read_json(smk.input.fit)
base_values = {name: fit[key]["value"] for name, key in RESULT_KEYS.items()}
base_intervals = {name: tuple(fit[key]["interval"]) for name, key in RESULT_KEYS.items()}
settings = smk.params.settings
key = inputs_key([settings, smk.params.fit_settings, smk.params.simulation],
                 [smk.input.fit, *smk.input.setups, *smk.input.masks])
shared = Path(smk.input.evaluations)
own = Path(smk.output.done).with_suffix(".evaluations.json")
if not own.is_file() and shared.is_file():
    stored = json.loads(shared.read_text())
    if stored["key"] != key:
        raise SystemExit(f"{shared}: key {stored['key']} is not this run's {key}")
    shutil.copy(shared, own)
if own.is_file() and json.loads(own.read_text())["key"] != key:
    raise SystemExit(f"{own}: stored key differs")
evaluations = EvaluationLog(own, key)
count = [0]


def progress(law: str, x: np.ndarray, loss: float) -> None:
    count[0] += 1
    log.info("evaluation %d (%s): loss %.5g px at %s", count[0], law, loss, np.round(x, 4).tolist())


one = {**settings, "candidates": [smk.params.candidate], "refit_evaluations": 0, "open_evaluations": 0}
diagnose(setups, smk.params.simulation, smk.params.fit_settings, one, base_values, base_intervals, evaluations, 1,
         progress)
Path(smk.output.done).write_text("done\n")
