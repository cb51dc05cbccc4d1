"""The package's names as a type checker sees them (CI also runs mypy over foam_mj and tests/typing_public_api.py)."""

import ast
from pathlib import Path

import foam_mj


def _type_checking_imports() -> dict[str, str]:
    """Name -> module of every ``from M import N as N`` under ``if TYPE_CHECKING:`` in foam_mj/__init__.py."""
    tree = ast.parse(Path(foam_mj.__file__).read_text())
    out: dict[str, str] = {}
    for node in tree.body:
        if isinstance(node, ast.If) and isinstance(node.test, ast.Name) and node.test.id == "TYPE_CHECKING":
            for imp in node.body:
                assert isinstance(imp, ast.ImportFrom) and imp.module, ast.dump(imp)
                for alias in imp.names:
                    assert alias.asname == alias.name, f"{alias.name}: re-exported as itself (import X as X)"
                    out[alias.name] = imp.module
    return out


def test_every_export_is_typed_from_its_module():
    # Imported on first use (PEP 562), the package's names were all Any to mypy and pyright (foam_mj.get_planner(...)
    # unchecked, a misspelt foam_mj.get_planer no error): each one is imported for type checkers from the module that
    # defines it, the same module as at run time.
    typed = _type_checking_imports()
    assert typed == foam_mj._EXPORTS
    for name, module in typed.items():
        assert getattr(foam_mj, name) is getattr(__import__(module, fromlist=[name]), name)
