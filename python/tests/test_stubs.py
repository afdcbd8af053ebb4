"""The type stubs (.pyi) name what the module has: every class, method, property and function, and no more."""
import ast
import inspect
import pathlib

import pytest

import priorslam

PACKAGE = pathlib.Path(priorslam.__file__).parent


def stub_names(stub):
    """{name: set of member names} of the classes, and the functions under the key None."""
    tree = ast.parse((PACKAGE / stub).read_text())
    out = {None: set()}
    for node in tree.body:
        if isinstance(node, ast.ClassDef) and not node.name.startswith("_"):
            members = set()
            for base in node.bases:  # members of a private stub base class count as the class's own
                for b in tree.body:
                    if isinstance(b, ast.ClassDef) and isinstance(base, ast.Name) and b.name == base.id:
                        members |= {f.name for f in b.body if isinstance(f, ast.FunctionDef)}
            members |= {f.name for f in node.body if isinstance(f, ast.FunctionDef)}
            out[node.name] = members
        elif isinstance(node, ast.FunctionDef):
            out[None].add(node.name)
    return out


def public_members(cls):
    return {n for n, _ in inspect.getmembers(cls) if not n.startswith("_") or n in ("__enter__", "__exit__", "__iter__", "__next__", "__init__")}


@pytest.mark.parametrize("stub, module", [("__init__.pyi", priorslam), ("eval.pyi", priorslam.eval)])
def test_stubs_match_the_module(stub, module):
    names = stub_names(stub)
    assert (PACKAGE / "py.typed").exists()
    functions = names.pop(None)
    for name in functions:
        assert callable(getattr(module, name)), name
    for cls_name, members in names.items():
        cls = getattr(module, cls_name)
        actual = public_members(cls)
        if cls is priorslam.Error:
            continue
        assert members - actual == set(), f"{cls_name}: stubbed but not bound"
        missing = {n for n in actual - members if not n.startswith("_")}
        assert missing == set(), f"{cls_name}: bound but not stubbed"
