"""YAML configs validated into typed dataclasses.

Every stage declares its own dataclass; ``load_config`` reads a YAML file and
builds that dataclass, rejecting unknown keys and wrong types with an error
that names the key and the file.  Command-line overrides (``--set a.b=1``)
are parsed with YAML scalar rules and validated the same way; nothing is
``exec``'d.
"""

from __future__ import annotations

import dataclasses
import types
import typing
from pathlib import Path
from typing import Any, TypeVar

import re

import yaml

from .errors import UserError
from .resources import CONFIG_DIR


class _Loader(yaml.SafeLoader):
    """SafeLoader that also reads ``1e-4`` as a float (YAML 1.1 wants ``1.0e-4``)."""


_Loader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"^[-+]?(?:[0-9][0-9_]*)(?:\.[0-9_]*)?[eE][-+]?[0-9]+$"),
    list("-+0123456789"),
)


def parse_yaml(text: str):
    return yaml.load(text, Loader=_Loader)

T = TypeVar("T")



def read_yaml(path: str | Path) -> dict:
    path = Path(path)
    if not path.is_file():
        raise UserError(f"config file not found: {path}")
    try:
        data = parse_yaml(path.read_bytes().decode("utf-8"))
    except UnicodeDecodeError as e:  # a binary file (or another encoding) given as a config
        raise UserError(f"{path}: not a YAML text file (byte {e.start} is not UTF-8)") from None
    except OSError as e:
        raise UserError(f"{path}: cannot read ({e.strerror})") from None
    except yaml.reader.ReaderError as e:  # control characters: a binary file that happens to decode
        code = e.character if isinstance(e.character, int) else ord(e.character)
        raise UserError(f"{path}: not a YAML text file (control character U+{code:04X} at offset {e.position})") from None
    except yaml.YAMLError as e:
        mark = getattr(e, "problem_mark", None)
        where = f" line {mark.line + 1}" if mark else ""
        problem = " ".join(str(getattr(e, "problem", None) or e).split())  # one line
        raise UserError(f"{path}:{where} is not valid YAML ({problem})") from None
    if data is None:
        data = {}
    if not isinstance(data, dict):
        raise UserError(f"{path}: top level must be a mapping, got {type(data).__name__}")
    return data


def from_dict(cls: type[T], data: Any, where: str = "", source: str = "config") -> T:
    """Build dataclass ``cls`` from plain data, checking keys and types recursively."""
    return _convert(cls, data, where, source)


def _convert(tp: Any, value: Any, where: str, source: str) -> Any:
    if tp in (dict, list):  # bare containers: any contents
        tp = dict[Any, Any] if tp is dict else list[Any]
    origin = typing.get_origin(tp)
    args = typing.get_args(tp)
    label = where or "<top>"
    if tp is Any:
        return value
    if dataclasses.is_dataclass(tp):
        if not isinstance(value, dict):
            raise UserError(f"{source}: '{label}' must be a mapping, got {type(value).__name__}")
        hints = typing.get_type_hints(tp)
        fields = {f.name: f for f in dataclasses.fields(tp) if f.init}
        unknown = sorted(set(value) - set(fields))
        if unknown:
            key = f"{where}.{unknown[0]}" if where else unknown[0]
            raise UserError(f"{source}: unknown key '{key}' (allowed: {', '.join(sorted(fields))})")
        kwargs = {}
        for name, f in fields.items():
            key = f"{where}.{name}" if where else name
            if name in value:
                kwargs[name] = _convert(hints[name], value[name], key, source)
            elif f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING:
                raise UserError(f"{source}: missing required key '{key}'")
        try:
            return tp(**kwargs)
        except (ValueError, TypeError) as e:
            raise UserError(f"{source}: '{label}': {e}") from None
    if origin in (typing.Union, types.UnionType):
        if value is None and type(None) in args:
            return None
        errors = []
        for a in args:
            if a is type(None):
                continue
            try:
                return _convert(a, value, where, source)
            except UserError as e:
                errors.append(str(e))
        raise UserError(errors[0] if errors else f"{source}: '{label}' has an invalid value {value!r}")
    if origin is typing.Literal:
        if value not in args:
            raise UserError(f"{source}: '{label}' must be one of {list(args)}, got {value!r}")
        return value
    if origin in (list, tuple):
        if not isinstance(value, (list, tuple)):
            raise UserError(f"{source}: '{label}' must be a list, got {type(value).__name__}")
        if origin is tuple and args and args[-1] is not Ellipsis:
            if len(value) != len(args):
                raise UserError(f"{source}: '{label}' must have {len(args)} items, got {len(value)}")
            return tuple(_convert(a, v, f"{where}[{i}]", source) for i, (a, v) in enumerate(zip(args, value)))
        item = args[0] if args else Any
        out = [_convert(item, v, f"{where}[{i}]", source) for i, v in enumerate(value)]
        return tuple(out) if origin is tuple else out
    if origin is dict:
        if not isinstance(value, dict):
            raise UserError(f"{source}: '{label}' must be a mapping, got {type(value).__name__}")
        kt, vt = args if args else (Any, Any)
        return {_convert(kt, k, where, source): _convert(vt, v, f"{where}.{k}", source) for k, v in value.items()}
    if tp is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise UserError(f"{source}: '{label}' must be a number, got {value!r}")
        return float(value)
    if tp is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise UserError(f"{source}: '{label}' must be an integer, got {value!r}")
        return value
    if tp is bool:
        if not isinstance(value, bool):
            raise UserError(f"{source}: '{label}' must be true or false, got {value!r}")
        return value
    if tp is str:
        if not isinstance(value, str):
            raise UserError(f"{source}: '{label}' must be a string, got {value!r}")
        return value
    raise TypeError(f"unsupported config type {tp!r} at {label}")


def read_config_with_base(path: Path, kind: str, _seen: tuple[Path, ...] = ()) -> dict:
    """Read ``path`` and, when it names a ``base:`` config (a name under ``configs/<kind>/`` or a
    path relative to this file), lay it over that config: mappings merge key by key, anything
    else replaces.  A variant then states only how it differs, so the two cannot drift apart."""
    data = read_yaml(path)
    base = data.pop("base", None)
    if base is None:
        return data
    if not isinstance(base, str):
        raise UserError(f"{path}: 'base' must be a config name or path, got {type(base).__name__}")
    relative = path.parent / base
    base_path = relative if relative.is_file() else resolve_config_path(base, kind)
    if base_path.resolve() in _seen + (path.resolve(),):
        raise UserError(f"{path}: 'base: {base}' leads back to a config that is already a base (a loop)")
    return _merged(read_config_with_base(base_path, kind, _seen + (path.resolve(),)), data)


def _merged(base: dict, top: dict) -> dict:
    out = dict(base)
    for key, value in top.items():
        out[key] = _merged(out[key], value) if isinstance(value, dict) and isinstance(out.get(key), dict) else value
    return out


def apply_overrides(data: dict, overrides: list[str] | None) -> dict:
    """Apply ``key.sub=value`` overrides; values are parsed as YAML scalars (typed, never executed)."""
    data = dict(data)
    for item in overrides or []:
        if "=" not in item:
            raise UserError(f"--set expects key=value, got '{item}'")
        key, raw = item.split("=", 1)
        try:
            value = parse_yaml(raw)
        except yaml.YAMLError:
            raise UserError(f"--set {key}: cannot parse value '{raw}'") from None
        node = data
        parts = key.split(".")
        for p in parts[:-1]:
            child = node.get(p)
            child = dict(child) if isinstance(child, dict) else {}
            node[p] = child
            node = child
        node[parts[-1]] = value
    return data


def load_config(cls: type[T], path: str | Path, overrides: list[str] | None = None) -> T:
    """Read ``path`` (YAML) into dataclass ``cls``; unknown keys and wrong types are UserErrors."""
    data = apply_overrides(read_yaml(path), overrides)
    return from_dict(cls, data, source=str(path))


def to_dict(obj: Any) -> Any:
    """Dataclass -> plain dict/list data, suitable for YAML or JSON."""
    if dataclasses.is_dataclass(obj):
        return {f.name: to_dict(getattr(obj, f.name)) for f in dataclasses.fields(obj)}
    if isinstance(obj, (list, tuple)):
        return [to_dict(v) for v in obj]
    if isinstance(obj, dict):
        return {k: to_dict(v) for k, v in obj.items()}
    return obj


def resolve_config_path(name_or_path: str, kind: str) -> Path:
    """Accept a path, or a bare name found under ``mnss_kit/configs/<kind>/NAME.yaml``."""
    p = Path(name_or_path)
    if p.is_file():
        return p
    candidate = CONFIG_DIR / kind / f"{name_or_path}.yaml"
    if candidate.is_file():
        return candidate
    known = sorted(q.stem for q in (CONFIG_DIR / kind).glob("*.yaml"))
    raise UserError(f"no {kind} config '{name_or_path}' (a path, or one of: {', '.join(known) or 'none'})")
