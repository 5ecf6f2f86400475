"""The type stub shipped in the wheel describes the module as it is: every public name, every
parameter (name, kind, default) and every property; mypy's stubtest too when it is installed."""

import ast
import inspect
import subprocess
import sys
from pathlib import Path

import pytest

import psi

STUB = Path(psi.__file__).with_name("__init__.pyi")


def stub_tree():
    assert STUB.is_file(), "the wheel ships psi/__init__.pyi"
    assert STUB.with_name("py.typed").is_file(), "the wheel ships psi/py.typed"
    return ast.parse(STUB.read_text())


def parameters(node, skip_first):
    """(name, kind, default) of a stub function's parameters, as inspect names them."""
    a = node.args
    out = []
    positional = a.posonlyargs + a.args
    defaults = [None] * (len(positional) - len(a.defaults)) + a.defaults
    for arg, default in list(zip(positional, defaults))[1 if skip_first else 0:]:
        out.append((arg.arg, "POSITIONAL_OR_KEYWORD", default))
    for arg, default in zip(a.kwonlyargs, a.kw_defaults):
        out.append((arg.arg, "KEYWORD_ONLY", default))
    return [(n, k, inspect.Parameter.empty if d is None else ast.literal_eval(d))
            for n, k, d in out]


def runtime_parameters(f):
    out = []
    for p in inspect.signature(f).parameters.values():
        if p.name == "self":
            continue
        kind = "KEYWORD_ONLY" if p.kind == p.KEYWORD_ONLY else "POSITIONAL_OR_KEYWORD"
        out.append((p.name, kind, p.default))
    return out


def first_definitions(body):
    """The first definition of each name (of overloads, the one with every default)."""
    out = {}
    for n in body:
        if isinstance(n, (ast.FunctionDef, ast.ClassDef)):
            out.setdefault(n.name, n)
    return out


def test_public_names_match():
    tree = stub_tree()
    stub_all = next(
        ast.literal_eval(n.value) for n in tree.body
        if isinstance(n, ast.Assign) and n.targets[0].id == "__all__"
    )
    assert sorted(stub_all) == sorted(psi.__all__)
    defined = first_definitions(tree.body)
    assert sorted(set(psi.__all__) - {"__version__"}) == sorted(defined)


def test_functions_and_methods_have_the_runtime_parameters():
    for name, node in first_definitions(stub_tree().body).items():
        runtime = getattr(psi, name)
        if isinstance(node, ast.FunctionDef):
            assert parameters(node, False) == runtime_parameters(runtime), name
            continue
        members = first_definitions(node.body)
        new = members.pop("__new__", None)
        if new is None:  # made by the package only
            with pytest.raises(TypeError):
                runtime()
        else:
            assert parameters(new, True) == runtime_parameters(runtime), name
        members.pop("__len__", None)
        public = {m for m in dir(runtime) if not m.startswith("_")}
        assert public == set(members), name
        for member, fn in members.items():
            attr = inspect.getattr_static(runtime, member)
            is_property = any(
                isinstance(d, ast.Name) and d.id == "property" for d in fn.decorator_list
            )
            assert is_property == (not callable(attr)), f"{name}.{member}"
            if not is_property:
                assert parameters(fn, True) == runtime_parameters(attr), f"{name}.{member}"


def test_mypy_stubtest_finds_nothing():
    pytest.importorskip("mypy.stubtest", reason="mypy is not installed")
    done = subprocess.run(
        [sys.executable, "-m", "mypy.stubtest", "psi"], capture_output=True, text=True
    )
    assert done.returncode == 0, done.stdout + done.stderr
