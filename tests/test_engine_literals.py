"""Engines by capability: outside ``soft_gym/engines/`` no code names an engine.

What an engine can do is asked by feature (:func:`soft_gym.engines.engine_supports`), its
default is :data:`soft_gym.engines.REFERENCE_ENGINE` and the reference engine's Python package is
:data:`soft_gym._distributions.REFERENCE_ENGINE_PACKAGE`. Every ``.py`` file of ``soft_gym`` (less
``soft_gym/engines/`` and :data:`PACKAGE_NAMES`), ``agents``, ``train`` and ``eval`` is parsed
with :mod:`ast`; a string constant equal to a registered engine's name fails the test unless it
is documentation (a bare string statement: a module, class or function docstring, or an
attribute's docstring).
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

from soft_gym.engines import ENGINES

pytestmark = pytest.mark.smoke

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("soft_gym", "agents", "train", "eval")
ENGINE_DIRECTORY = ROOT / "soft_gym" / "engines"
PACKAGE_NAMES = ROOT / "soft_gym" / "_distributions.py"
"""The one file that names an engine's Python package (a distribution, for version look-ups)."""
SKIPPED_DIRECTORIES = {"__pycache__", "runs", "results"}


def _documentation(tree: ast.AST) -> set[int]:
    """``id`` of every string constant that stands alone as a statement (a docstring)."""
    return {id(node.value) for node in ast.walk(tree)
            if isinstance(node, ast.Expr) and isinstance(node.value, ast.Constant)
            and isinstance(node.value.value, str)}


def engine_names_in(source: str, names: set[str]) -> list[tuple[int, str]]:
    """``(line, name)`` of every string constant of ``source`` in ``names``, less docstrings."""
    tree = ast.parse(source)
    documentation = _documentation(tree)
    return sorted((node.lineno, node.value) for node in ast.walk(tree)
                  if isinstance(node, ast.Constant) and isinstance(node.value, str)
                  and node.value in names and id(node) not in documentation)


def _source_files() -> list[Path]:
    files = []
    for package in PACKAGES:
        for path in sorted((ROOT / package).rglob("*.py")):
            if (path.is_relative_to(ENGINE_DIRECTORY) or path == PACKAGE_NAMES
                    or not SKIPPED_DIRECTORIES.isdisjoint(path.relative_to(ROOT).parts)):
                continue
            files.append(path)
    return files


def test_the_scan_finds_an_engine_name_and_passes_docstrings():
    source = ('"""Runs on "mujoco"."""\n'
              'LIMIT = 3\n'
              '"""mujoco"""\n'
              'def f(engine="pybullet"):\n'
              '    """pybullet"""\n'
              '    return engine == "mujoco" or f"{engine}" == "bullet"\n')
    assert engine_names_in(source, {"pybullet", "mujoco"}) == [(4, "pybullet"), (6, "mujoco")]


def test_the_scan_covers_every_package():
    files = {path.relative_to(ROOT).as_posix() for path in _source_files()}
    for expected in ("soft_gym/envs/vector.py", "train/trainer.py", "eval/suite/store.py",
                     "agents/policies/sb3.py"):
        assert expected in files
    assert not any(name.startswith("soft_gym/engines/") for name in files)
    assert "soft_gym/_distributions.py" not in files


def test_no_engine_name_outside_the_engines():
    names = set(ENGINES)
    found = [f"{path.relative_to(ROOT)}:{line}: {name!r}" for path in _source_files()
             for line, name in engine_names_in(path.read_text(encoding="utf-8"), names)]
    assert not found, ("ask what an engine can do by feature (soft_gym.engines.engine_supports, "
                       "engines_supporting), default to REFERENCE_ENGINE, and name the reference "
                       "engine's package by soft_gym._distributions.REFERENCE_ENGINE_PACKAGE:\n" + "\n".join(found))
