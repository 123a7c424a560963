"""
The lab sits beside the driver: a robot builds and runs skin_driver without skin_lab.

Nothing the driver package installs (skin_driver/, launch/) imports the lab or starts one of its
modules; the driver's manifest does not depend on it and its setup.py does not package it.
"""

import ast
import pathlib
import re
import xml.etree.ElementTree as ElementTree

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]
LAB = 'skin_lab'
# A string that is a lab module's name: what importlib or `python -m` would be given.
LAB_NAME = re.compile(rf'{LAB}(\.\w+)*')


def _driver_sources():
    return sorted(p for folder in ('skin_driver', 'launch') for p in (ROOT / folder).rglob('*.py'))


def lab_uses(source):
    """Return the lab modules a Python source imports or names as a module string."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            found += [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.level == 0:
            found.append(node.module)
        elif isinstance(node, ast.Constant) and isinstance(node.value, str):
            found += [node.value] if LAB_NAME.fullmatch(node.value) else []
    return [name for name in found if name.split('.')[0] == LAB]


@pytest.mark.parametrize('path', _driver_sources(), ids=lambda p: str(p.relative_to(ROOT)))
def test_the_driver_never_uses_the_lab(path):
    assert lab_uses(path.read_text()) == []


def test_the_check_finds_each_way_of_using_the_lab():
    # A checker that saw none of these could never fail.
    source = ('import skin_lab.oracle\nfrom skin_lab.bench import cli\n'
              "importlib.import_module('skin_lab.evaluate')\nspawn(['-m', 'skin_lab.demo'])\n"
              '"""Run ``python -m skin_lab.evaluate`` (a docstring only names it)."""\n')
    assert lab_uses(source) == ['skin_lab.oracle', 'skin_lab.bench', 'skin_lab.evaluate',
                                'skin_lab.demo']


def test_the_driver_package_neither_depends_on_nor_packages_the_lab():
    manifest = ElementTree.parse(ROOT / 'package.xml').getroot()
    assert LAB not in {e.text for e in manifest if e.tag.endswith('depend')}
    # setup.py's find_packages() takes only folders that are Python packages from the root
    # down: skin_lab/ is not one (its Python package is skin_lab/skin_lab/), so none of it.
    assert 'find_packages(' in (ROOT / 'setup.py').read_text()
    assert (ROOT / 'skin_driver' / '__init__.py').is_file()
    assert not (ROOT / LAB / '__init__.py').exists()
    assert LAB not in (ROOT / 'setup.py').read_text()
