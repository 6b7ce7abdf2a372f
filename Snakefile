# rheo: Herschel-Bulkley rheology from video through differentiable simulation.
from pathlib import Path

from snakemake.exceptions import WorkflowError
from snakemake.utils import min_version

from rheo.config import ConfigError, load_schema, load_yaml, validated

min_version("9.0")


try:
    load_yaml("config/config.yaml")  # syntax and duplicate keys, which Snakemake's reader lets pass
except ConfigError as error:
    raise WorkflowError(str(error)) from None


configfile: "config/config.yaml"


report: "workflow/report/workflow.rst"


try:
    validated(config, load_schema(Path(workflow.basedir) / "workflow/schemas/config.schema.yaml"),
              "config/config.yaml (with --config)")
except ConfigError as error:
    raise WorkflowError(str(error)) from None


include: "workflow/rules/common.smk"
include: "workflow/rules/thesis.smk"
include: "workflow/rules/calibrate.smk"
include: "workflow/rules/proxy.smk"
include: "workflow/rules/synthesize.smk"
include: "workflow/rules/ingest.smk"
include: "workflow/rules/matte.smk"
include: "workflow/rules/seed.smk"
include: "workflow/rules/velocity.smk"
include: "workflow/rules/fit.smk"
include: "workflow/rules/novel.smk"
include: "workflow/rules/report.smk"
include: "workflow/rules/virheometry.smk"
include: "workflow/rules/convergence.smk"
include: "workflow/rules/concealed.smk"
include: "workflow/rules/diagnose.smk"


rule all:
    input:
        "results/thesis/collapse.html",
