"""Configuration files read strictly: YAML without duplicate keys, finite numbers only, a schema with its defaults,
and every problem told in one sentence that names the file and the key."""

from __future__ import annotations

import copy
import difflib
import math
from pathlib import Path
from typing import Any

import yaml
from jsonschema import Draft202012Validator, validators
from jsonschema.exceptions import ValidationError, best_match

ROOT = Path(__file__).resolve().parents[1]
WORKFLOW_CONFIG = ROOT / "config/config.yaml"


class ConfigError(ValueError):
    """A configuration file or value that rheo cannot use; the message names the file and the key."""


class _StrictLoader(yaml.SafeLoader):
    """YAML's safe loader that refuses a key given twice in one mapping."""


class _DuplicateKey(yaml.MarkedYAMLError):
    pass


def _mapping_without_duplicates(loader: _StrictLoader, node: yaml.MappingNode, deep: bool = False) -> dict:
    seen: set = set()
    for key_node, _ in node.value:
        key = loader.construct_object(key_node, deep=deep)
        if key in seen:
            raise _DuplicateKey(problem=f"the key {key!r} is given twice", problem_mark=key_node.start_mark)
        seen.add(key)
    return loader.construct_mapping(node, deep=deep)


_StrictLoader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _mapping_without_duplicates)


def load_yaml(path: str | Path) -> Any:
    """The content of a YAML file; a syntax error or a duplicate key is a ConfigError naming the line."""
    path = Path(path)
    try:
        text = path.read_text()
    except OSError as error:
        raise ConfigError(f"{path}: cannot be read ({error.strerror or error})") from None
    try:
        return yaml.load(text, Loader=_StrictLoader)
    except _DuplicateKey as error:
        raise ConfigError(f"{path}: line {error.problem_mark.line + 1}: {error.problem} (the last one would win "
                          "unnoticed)") from None
    except yaml.MarkedYAMLError as error:
        mark = error.problem_mark or error.context_mark
        where = f" (line {mark.line + 1}, column {mark.column + 1})" if mark else ""
        raise ConfigError(f"{path}: not valid YAML{where}: {error.problem or error.context}") from None
    except yaml.YAMLError as error:
        raise ConfigError(f"{path}: not valid YAML: {error}") from None


def key_name(path: list | tuple) -> str:
    """A key's dotted name (list items by index): ``proxy.position[0]``."""
    name = ""
    for part in path:
        name += f"[{part}]" if isinstance(part, int) else f".{part}" if name else str(part)
    return name or "the document"


def check_finite(data: Any, source: str, path: tuple = ()) -> None:
    """Refuse NaN and infinity anywhere in ``data``."""
    if isinstance(data, float) and not math.isfinite(data):
        raise ConfigError(f"{source}: {key_name(path)}: {data} is not a finite number")
    if isinstance(data, dict):
        for key, value in data.items():
            check_finite(value, source, (*path, key))
    elif isinstance(data, list):
        for i, value in enumerate(data):
            check_finite(value, source, (*path, i))


def _with_defaults(validator_class: type) -> type:
    """A validator class that fills in each property's default (a copy) where the property is missing."""
    validate_properties = validator_class.VALIDATORS["properties"]

    def properties_with_defaults(validator, properties, instance, schema):
        if isinstance(instance, dict):
            for name, subschema in properties.items():
                if "default" in subschema:
                    instance.setdefault(name, copy.deepcopy(subschema["default"]))
        yield from validate_properties(validator, properties, instance, schema)

    return validators.extend(validator_class, {"properties": properties_with_defaults})


_DefaultingValidator = _with_defaults(Draft202012Validator)


def _shown(value: Any, limit: int = 60) -> str:
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _wanted_types(error: ValidationError) -> list[str]:
    """The types a "type" error asked for."""
    return error.validator_value if isinstance(error.validator_value, list) else [error.validator_value]


def _sentence(error: ValidationError) -> str:
    """What is wrong, said about the value the user wrote."""
    value, rule = error.instance, error.validator
    if rule == "type":
        return f"{_shown(value)} is not {' or '.join(_TYPE_WORDS.get(t, t) for t in _wanted_types(error))}"
    if rule == "enum":
        return f"{_shown(value)} is not one of {', '.join(map(str, error.validator_value))}"
    if rule in ("minimum", "maximum", "exclusiveMinimum", "exclusiveMaximum"):
        words = {"minimum": "at least", "maximum": "at most", "exclusiveMinimum": "above",
                 "exclusiveMaximum": "below"}[rule]
        return f"{_shown(value)} must be {words} {error.validator_value}"
    if rule == "additionalProperties" and isinstance(error.schema.get("properties"), dict):
        known = list(error.schema["properties"])
        extra = [key for key in value if key not in known]
        close = {key: difflib.get_close_matches(str(key), known, n=1) for key in extra}
        guesses = [f"{key!r} (did you mean {close[key][0]!r}?)" if close[key] else repr(key) for key in extra]
        return f"{', '.join(guesses)} {'is not a key' if len(extra) == 1 else 'are not keys'} here"
    return error.message if len(error.message) <= 200 else error.message[:197] + "..."


def _reads_as_number(text: str) -> bool:
    try:
        return math.isfinite(float(text))
    except ValueError:
        return False


_TYPE_WORDS = {"number": "a number", "integer": "an integer", "string": "a string",
               "array": "a list", "object": "a mapping of keys", "boolean": "true or false", "null": "null"}


def _numbers_from_text(data: dict, errors) -> bool:
    """Read as numbers the texts that stand where the schema wants a number (``1e8``, which YAML 1.1 reads as text,
    and every value given in a mapping on Snakemake's command line); whether any was changed."""
    changed = False
    for error in errors:
        if error.validator != "type" or not isinstance(error.instance, str) or not _reads_as_number(error.instance):
            continue
        wanted, number = _wanted_types(error), float(error.instance)
        if "integer" in wanted and number.is_integer():
            value: float | int = int(number)
        elif "number" in wanted:
            value = number
        else:
            continue
        *parents, last = error.absolute_path
        container = data
        for key in parents:
            container = container[key]
        container[last] = value
        changed = True
    return changed


def validated(data: Any, schema: dict, source: str) -> dict:
    """``data`` checked against ``schema`` (finite numbers, types, ranges) with its defaults filled in (in place)."""
    if not isinstance(data, dict):
        raise ConfigError(f"{source}: expected a mapping of keys (key: value lines), found "
                          f"{'nothing' if data is None else type(data).__name__}")
    check_finite(data, source)
    validator = _DefaultingValidator(schema)
    while _numbers_from_text(data, validator.iter_errors(data)):
        pass
    error = best_match(validator.iter_errors(data))
    if error is not None:
        description = error.schema.get("description") if isinstance(error.schema, dict) else None
        about = f" ({description.split(';')[0]})" if description and len(description) <= 80 else ""
        raise ConfigError(f"{source}: {key_name(error.absolute_path)}{about}: {_sentence(error)}")
    return data


def load_schema(path: str | Path) -> dict:
    with open(path) as f:
        return yaml.safe_load(f)


def load_checked(path: str | Path, schema: dict) -> dict:
    """A YAML file read strictly and validated against ``schema``, its defaults filled in."""
    return validated(load_yaml(path), schema, str(path))


def workflow_settings(path: str | Path = WORKFLOW_CONFIG) -> dict:
    """The workflow's configuration (config/config.yaml unless told) with the schema's defaults filled in."""
    return load_checked(path, load_schema(ROOT / "workflow/schemas/config.schema.yaml"))


def load_named(path: Path, schema: dict) -> dict:
    """A config file of one named thing (an experiment, a concealed case), whose ``name`` must be its file's stem."""
    data = load_checked(path, schema)
    if data["name"] != path.stem:
        raise ConfigError(f"{path}: name {data['name']!r} differs from the file name {path.stem!r}")
    return data
