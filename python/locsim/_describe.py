"""Reads a Python localizer's declarations without running it, for the host's plugin loader
(plugins/python: `locsim_localizer_load`), which runs

    python3 -I -S _describe.py FILE

in a process of its own (no user code, no numpy, nothing imported but the standard library) and
reads one fact per line, tab-separated:

    name<TAB>landmark_pf
    description<TAB>Particle filter on landmarks
    class<TAB>LandmarkPF
    readings<TAB>10                        the on_* handlers defined, as LOCSIM_READING_BIT bits
    param<TAB>NAME<TAB>int|double|bool|string<TAB>DEFAULT<TAB>MIN<TAB>MAX<TAB>DOC

A problem exits 1 with 'FILE:LINE: message' on stderr. The file must define exactly one class
derived from locsim.Localizer; its `name` and `params` must be literals (docs/python.md): `params`
a list of locsim.param(...) calls, to which the SDK's lists may be added
(`[...] + locsim.detection_noise_params() + locsim.motion_noise_params()`, from noise_params.py).
"""
import ast
import importlib.util
import math
import os
import re
import sys

HANDLERS = {"on_odometry": 1, "on_imu": 2, "on_landmarks": 3, "on_beacon_ranges": 4, "on_laser": 5}
TYPES = {"int": "int", "float": "double", "bool": "bool", "str": "string"}
NAME = re.compile(r"[a-z0-9_]+\Z")


class Problem(Exception):
    def __init__(self, line, message):
        super().__init__(message)
        self.line = line


def is_localizer_base(node):
    return (isinstance(node, ast.Name) and node.id == "Localizer") or \
        (isinstance(node, ast.Attribute) and node.attr == "Localizer")


def literal(node, what):
    try:
        return ast.literal_eval(node)
    except ValueError:
        raise Problem(node.lineno, f"{what} must be a literal (a number, True/False or a string)") from None


def flat(text):
    return " ".join(str(text).split())


def number(value, kind, what, line):
    if kind == "int":
        if isinstance(value, bool) or not isinstance(value, int):
            raise Problem(line, f"{what} must be an int")
        return str(value)
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise Problem(line, f"{what} must be a finite number")
    return repr(float(value))


def read_param(call):
    if not (isinstance(call, ast.Call) and ((isinstance(call.func, ast.Name) and call.func.id == "param") or
                                            (isinstance(call.func, ast.Attribute) and call.func.attr == "param"))):
        raise Problem(call.lineno, "each entry of params must be a call locsim.param(name, type, default, min, max, doc)")
    fields = ["name", "type", "default", "min", "max", "doc"]
    given = dict(zip(fields, call.args))
    if len(call.args) > len(fields):
        raise Problem(call.lineno, "locsim.param takes name, type, default, min, max, doc")
    for keyword in call.keywords:
        if keyword.arg not in fields or keyword.arg in given:
            raise Problem(call.lineno, f"locsim.param: unexpected or repeated argument {keyword.arg!r}")
        given[keyword.arg] = keyword.value
    for required in ("name", "type", "default"):
        if required not in given:
            raise Problem(call.lineno, f"locsim.param: no {required}")
    name = literal(given["name"], "a parameter's name")
    if not isinstance(name, str) or not NAME.match(name):
        raise Problem(call.lineno, f"parameter name {name!r} must be [a-z0-9_]+")
    type_node = given["type"]
    if not (isinstance(type_node, ast.Name) and type_node.id in TYPES):
        raise Problem(call.lineno, f"parameter {name!r}: its type must be int, float, bool or str")
    default = literal(given["default"], f"parameter {name!r}'s default")
    low = literal(given["min"], f"parameter {name!r}'s min") if "min" in given else None
    high = literal(given["max"], f"parameter {name!r}'s max") if "max" in given else None
    doc = literal(given["doc"], f"parameter {name!r}'s doc") if "doc" in given else ""
    return param_line(name, type_node.id, default, low, high, doc, call.lineno)


def param_line(name, type_name, default, low, high, doc, line):
    """(name, the fact line) of one parameter, checked as locsim.param checks it."""
    kind = TYPES[type_name]
    if kind == "bool":
        if not isinstance(default, bool):
            raise Problem(line, f"parameter {name!r}: default must be True or False")
        text = "1" if default else "0"
    elif kind == "string":
        if not isinstance(default, str):
            raise Problem(line, f"parameter {name!r}: default must be a string")
        text = flat(default)
    else:
        text = number(default, kind, f"parameter {name!r}'s default", line)
    bounds = []
    for bound, label in ((low, "min"), (high, "max")):
        if bound is None or kind in ("bool", "string"):
            bounds.append("")
        else:
            bounds.append(number(bound, kind, f"parameter {name!r}'s {label}", line))
    if kind in ("int", "double"):
        if low is not None and default < low or high is not None and default > high:
            raise Problem(line, f"parameter {name!r}: default {default} outside [{low}, {high}]")
    return name, "\t".join(["param", name, kind, text, bounds[0], bounds[1], flat(doc)])


def sdk_module():
    """noise_params.py, read from beside this file (run with -I: not on sys.path)."""
    spec = importlib.util.spec_from_file_location(
        "locsim_noise_params", os.path.join(os.path.dirname(os.path.abspath(__file__)), "noise_params.py"))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def param_entries(node):
    """The nodes of a `params` value: a list (or tuple) of locsim.param calls, or such lists and
    the SDK's list calls added together. Each entry: a call node, or (a row, its line)."""
    if isinstance(node, (ast.List, ast.Tuple)):
        return list(node.elts)
    if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Add):
        return param_entries(node.left) + param_entries(node.right)
    if isinstance(node, ast.Call) and not node.args:
        called = node.func.attr if isinstance(node.func, ast.Attribute) else \
            node.func.id if isinstance(node.func, ast.Name) else None
        module = sdk_module()
        if called in module.LISTS:
            defaults = {k.arg: literal(k.value, f"{called}'s {k.arg}") for k in node.keywords}
            try:
                rows = module.with_defaults(module.LISTS[called], defaults)
            except ValueError as error:
                raise Problem(node.lineno, f"{called}: {error}") from None
            return [(row, node.lineno) for row in rows]
    raise Problem(node.lineno, "params must be a list of locsim.param(...) calls (to which "
                               "locsim.detection_noise_params(), locsim.motion_noise_params() and "
                               "locsim.lost_params() may be added)")


def describe(path):
    with open(path, encoding="utf-8") as f:
        source = f.read()
    try:
        tree = ast.parse(source, filename=path)
    except SyntaxError as error:
        raise Problem(error.lineno or 1, f"SyntaxError: {error.msg}") from None
    classes = [n for n in tree.body if isinstance(n, ast.ClassDef) and any(is_localizer_base(b) for b in n.bases)]
    if len(classes) != 1:
        raise Problem(classes[1].lineno if len(classes) > 1 else 1,
                      f"defines {len(classes)} classes derived from locsim.Localizer; a localizer's file defines one")
    cls = classes[0]
    stem = os.path.splitext(os.path.basename(path))[0].lower()
    name = re.sub(r"[^a-z0-9_]", "_", stem)
    params, handlers = [], set()
    doc = ast.get_docstring(cls)
    description = flat(doc.strip().splitlines()[0]) if doc else f"Python localizer {cls.name}"
    for statement in cls.body:
        if isinstance(statement, ast.FunctionDef):
            handlers.add(statement.name)
        targets = statement.targets if isinstance(statement, ast.Assign) else \
            [statement.target] if isinstance(statement, ast.AnnAssign) and statement.value is not None else []
        for target in targets:
            if not isinstance(target, ast.Name):
                continue
            if target.id == "name":
                name = literal(statement.value, "name")
                if not isinstance(name, str) or not NAME.match(name):
                    raise Problem(statement.lineno, f"name {name!r} must be [a-z0-9_]+")
            elif target.id == "params":
                seen = set()
                for entry in param_entries(statement.value):
                    if isinstance(entry, tuple):  # a row of the SDK's lists
                        (name_, type_, default, low, high, doc_), lineno = entry
                        param_name, line = param_line(name_, type_.__name__, default, low, high, doc_, lineno)
                    else:
                        param_name, line = read_param(entry)
                        lineno = entry.lineno
                    if param_name in seen:
                        raise Problem(lineno, f"parameter {param_name!r} declared twice")
                    seen.add(param_name)
                    params.append(line)
    if "estimate" not in handlers:
        raise Problem(cls.lineno, f"class {cls.name} defines no estimate(self) method")
    bits = sum(1 << kind for handler, kind in HANDLERS.items() if handler in handlers)
    lines = [f"name\t{name}", f"description\t{description}", f"class\t{cls.name}", f"readings\t{bits}"]
    return lines + params


def main():
    path = sys.argv[1]
    try:
        lines = describe(path)
    except Problem as problem:
        print(f"{path}:{problem.line}: {problem}", file=sys.stderr)
        return 1
    except (OSError, UnicodeDecodeError) as error:
        print(f"{path}: {error}", file=sys.stderr)
        return 1
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
