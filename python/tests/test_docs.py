"""Every public name has a docstring and a stub in __init__.pyi; the native module's stub lists
what the module defines."""
import ast
import inspect
from pathlib import Path

import bsarap
from bsarap import _bsarap

PKG = Path(bsarap.__file__).parent


def stub_names(path):
    tree = ast.parse(path.read_text())
    names = {}
    for node in tree.body:
        if isinstance(node, (ast.FunctionDef, ast.ClassDef)):
            members = set()
            if isinstance(node, ast.ClassDef):
                members = {n.name for n in node.body if isinstance(n, ast.FunctionDef)}
                members |= {n.target.id for n in node.body if isinstance(n, ast.AnnAssign)}
            names[node.name] = members
        elif isinstance(node, ast.AnnAssign):
            names[node.target.id] = set()
    return names


def test_public_api_documented_and_stubbed():
    stubs = stub_names(PKG / "__init__.pyi")
    for name in bsarap.__all__:
        obj = getattr(bsarap, name)
        assert name in stubs, f"{name} missing from __init__.pyi"
        if inspect.isclass(obj) or inspect.isfunction(obj):
            assert inspect.getdoc(obj), f"{name} has no docstring"
        if inspect.isclass(obj) and name != "BsarapError":
            for member, value in vars(obj).items():
                if member.startswith("_"):
                    continue
                assert member in stubs[name], f"{name}.{member} missing from __init__.pyi"
                target = value.fget if isinstance(value, property) else getattr(value, "__func__", value)
                assert inspect.getdoc(target), f"{name}.{member} has no docstring"


def test_native_stub_complete():
    stubs = stub_names(PKG / "_bsarap.pyi")
    for name in dir(_bsarap):
        if name.startswith("_"):
            continue
        assert name in stubs, f"_bsarap.{name} missing from _bsarap.pyi"
        obj = getattr(_bsarap, name)
        if inspect.isclass(obj) and name != "BsarapError":
            for member in dir(obj):
                if not member.startswith("_"):
                    assert member in stubs[name], f"_bsarap.{name}.{member} missing from _bsarap.pyi"
