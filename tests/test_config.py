"""Configuration files read strictly: duplicate keys, NaN and infinity, numbers written as text, schema errors in one
sentence naming the file and the key, and defaults filled in without sharing; generated configs never get past the
check with a value the schema forbids, and never raise anything but a ConfigError."""

import copy
import math
from pathlib import Path

import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from rheo.config import ConfigError, load_checked, load_named, load_schema, load_yaml, validated

ROOT = Path(__file__).resolve().parents[1]
SCHEMA = load_schema(ROOT / "workflow/schemas/experiment.schema.yaml")
CASE_SCHEMA = load_schema(ROOT / "workflow/schemas/concealed_case.schema.yaml")
TINY = yaml.safe_load((ROOT / "config/experiments/tiny.yaml").read_text())


def test_a_key_given_twice_is_named_with_its_line(tmp_path):
    path = tmp_path / "twice.yaml"
    path.write_text("name: twice\nkind: virtual\nkind: real\n")
    with pytest.raises(ConfigError, match=r"twice\.yaml: line 3: the key 'kind' is given twice"):
        load_yaml(path)


def test_a_syntax_error_names_the_file_line_and_column(tmp_path):
    path = tmp_path / "broken.yaml"
    path.write_text("name: broken\n  x: [1,\n")
    with pytest.raises(ConfigError, match=r"broken\.yaml: not valid YAML \(line 2, column 4\)"):
        load_yaml(path)


@pytest.mark.parametrize("content, found", [("- a\n- b\n", "list"), ("", "nothing"), ("just text\n", "str")])
def test_a_file_that_is_not_a_mapping_is_refused(tmp_path, content, found):
    path = tmp_path / "odd.yaml"
    path.write_text(content)
    with pytest.raises(ConfigError, match=rf"odd\.yaml: expected a mapping of keys .* found {found}"):
        load_checked(path, SCHEMA)


@pytest.mark.parametrize("key, value, message", [
    (("material", "tau_y"), math.nan, "material.tau_y: nan is not a finite number"),
    (("proxy", "position"), [math.nan, 0.0, 0.5], r"proxy.position\[0\]: nan is not a finite number"),
    (("simulation", "duration"), math.inf, "simulation.duration: inf is not a finite number"),
    (("fit", "tolerance"), -math.inf, "fit.tolerance: -inf is not a finite number"),
    (("material", "lam"), -5000.0, r"material.lam \(Lame lambda \(Pa\)\): -5000.0 must be at least 0"),
    (("simulation", "resolution"), 300, "simulation.resolution .*: 300 must be at most 256"),
    (("simulation", "substeps"), "1e8", "simulation.substeps: 100000000 must be at most 100000"),
    (("simulation", "frames"), 2.5, r"simulation.frames .*: 2.5 is not an integer"),
    (("cameras", "widht"), 640, r"cameras .*: 'widht' \(did you mean 'width'\?\) is not a key here"),
    (("fit", "initial_guess", "tau_y"), math.nan, "fit.initial_guess.tau_y: nan is not a finite number"),
])
def test_a_bad_value_is_one_sentence_naming_the_file_and_the_key(key, value, message):
    exp = copy.deepcopy(TINY)
    node = exp
    for part in key[:-1]:
        node = node.setdefault(part, {})
    node[key[-1]] = value
    with pytest.raises(ConfigError, match=rf"^tiny\.yaml: {message}") as caught:
        validated(exp, SCHEMA, "tiny.yaml")
    assert "\n" not in str(caught.value)


def test_numbers_written_as_text_are_read_as_numbers_where_the_schema_wants_one():
    exp = copy.deepcopy(TINY)
    exp["simulation"].update(resolution="24", duration="2.5e-1")
    checked = validated(exp, SCHEMA, "tiny.yaml")
    assert checked["simulation"]["resolution"] == 24 and checked["simulation"]["duration"] == 0.25
    exp = copy.deepcopy(TINY)
    exp["description"] = 12  # a number where text is wanted stays an error
    with pytest.raises(ConfigError, match=r"description \(free text\): 12 is not a string"):
        validated(exp, SCHEMA, "tiny.yaml")


def test_defaults_are_filled_in_and_not_shared_between_documents():
    first, second = validated(copy.deepcopy(TINY), SCHEMA, "a"), validated(copy.deepcopy(TINY), SCHEMA, "b")
    assert first["matte"]["threshold"] is None and first["simulation"]["gravity"] == [0.0, -9.8, 0.0]
    first["simulation"]["gravity"][1] = -1.0
    assert second["simulation"]["gravity"][1] == -9.8 and SCHEMA["properties"]["simulation"]["properties"][
        "gravity"]["default"][1] == -9.8


def test_every_real_experiment_file_passes():
    for path in sorted((ROOT / "config/experiments").rglob("*.yaml")):
        # concealed cases: the hand-written ones and those of drawn suites (a folder with the seed in suite.json)
        concealed = path.parent.name == "concealed" or (path.parent / "suite.json").is_file()
        if concealed:
            load_named(path, CASE_SCHEMA)
        else:
            load_checked(path, SCHEMA)


HOSTILE_VALUES = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True), st.integers(-10**12, 10**12), st.text(max_size=8), st.none(),
    st.booleans(), st.lists(st.floats(allow_nan=True), max_size=4), st.dictionaries(st.text(max_size=4), st.none(),
                                                                                    max_size=2))


def _leaf_paths(node, path=()):
    if isinstance(node, dict):
        for key, value in node.items():
            yield from _leaf_paths(value, (*path, key))
    else:
        yield path


LEAVES = list(_leaf_paths(TINY))


@settings(max_examples=150, deadline=None)
@given(st.sampled_from(LEAVES), HOSTILE_VALUES)
def test_a_generated_hostile_value_is_a_config_error_or_a_valid_config(leaf, value):
    exp = copy.deepcopy(TINY)
    node = exp
    for part in leaf[:-1]:
        node = node[part]
    node[leaf[-1]] = value
    try:
        checked = validated(exp, SCHEMA, "tiny.yaml")
    except ConfigError as error:
        assert str(error).startswith("tiny.yaml: ") and "\n" not in str(error)
        return
    from jsonschema import Draft202012Validator

    Draft202012Validator(SCHEMA).validate(checked)  # what passed is valid, with finite numbers only
    assert all(math.isfinite(x) for x in _numbers(checked))


def _numbers(node):
    if isinstance(node, dict):
        for value in node.values():
            yield from _numbers(value)
    elif isinstance(node, list):
        for value in node:
            yield from _numbers(value)
    elif isinstance(node, float):
        yield node
