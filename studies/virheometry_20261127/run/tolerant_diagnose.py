"""The diagnose stage (stages/diagnose.py) with stored evaluations replayed within tolerant.TOLERANCE; run as the
stage script with the rule's `snakemake` object (run_fits.py --one JOBS INDEX)."""
import logging
import runpy

import tolerant

try:
    runpy.run_path("stages/diagnose.py", init_globals={"snakemake": snakemake}, run_name="__main__")  # noqa: F821
finally:
    logging.getLogger("rheo.stage").info("replayed %d points within %.1e of a stored one (largest %.2e)",
                                         len(tolerant.matched), tolerant.TOLERANCE, max(tolerant.matched, default=0))
