"""
Each package.xml declares every package its code imports, so rosdep installs them.

The driver's (the repository's root) covers skin_driver/, launch/ and the tests; the lab's
(skin_lab/package.xml) covers skin_lab/skin_lab/, which imports the driver as a package.
"""

import ast
import pathlib
import sys
import xml.etree.ElementTree as ElementTree

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]
# Python module -> rosdep key, for the modules whose key differs from their name.
ROSDEP_KEYS = {'cv2': 'python3-opencv', 'hypothesis': 'python3-hypothesis',
               'matplotlib': 'python3-matplotlib', 'numpy': 'python3-numpy',
               'pytest': 'python3-pytest', 'rosbags': 'python3-rosbags-pip',
               'serial': 'python3-serial',
               'skimage': 'python3-skimage', 'yaml': 'python3-yaml'}
# Imported only by a developer's tool and its tests, pinned in tools/requirements.txt, which
# tools/setup.sh installs with or without a system ROS: the rehosted board's emulator (unicorn
# 2.1, newer than the distributions' python3-unicorn, and no rosdep key found for it).
PIP_ONLY = {'unicorn'}
# This project's own packages and the tests' helper modules. The tests import the lab too,
# which the driver's package.xml cannot declare: the lab depends on the driver.
OWN = {'skin_driver', 'skin_msgs', 'skin_lab', 'rosutil', 'pipeline', 'port_reader', 'conftest',
       'taxel_presses'}
# Each manifest, the folders whose imports it declares, and what is the package's own.
MANIFESTS = {'package.xml': (('skin_driver', 'launch', 'test'), OWN),
             'skin_lab/package.xml': (('skin_lab/skin_lab',), {'skin_lab'})}


def _imported_modules(folders=('skin_driver', 'launch', 'test')):
    modules = {}
    for folder in folders:
        for path in (ROOT / folder).rglob('*.py'):
            for node in ast.walk(ast.parse(path.read_text())):
                if isinstance(node, ast.Import):
                    names = [alias.name for alias in node.names]
                elif isinstance(node, ast.ImportFrom) and node.level == 0:
                    names = [node.module]
                else:
                    continue
                for name in names:
                    modules.setdefault(name.split('.')[0], path.relative_to(ROOT))
    return modules


def _declared(manifest='package.xml'):
    root = ElementTree.parse(ROOT / manifest).getroot()
    return {element.text for element in root
            if element.tag.endswith('depend') and element.text}


@pytest.mark.parametrize('manifest', MANIFESTS)
def test_every_imported_package_is_declared_in_package_xml(manifest):
    folders, own = MANIFESTS[manifest]
    third_party = {name: path for name, path in _imported_modules(folders).items()
                   if name not in sys.stdlib_module_names and name not in own | PIP_ONLY}
    # matplotlib (the benchmark plots, the tests too) is the import a workstation lacked.
    assert 'matplotlib' in third_party
    declared = _declared(manifest)
    missing = {f'{name} (imported by {path})': ROSDEP_KEYS.get(name, name)
               for name, path in third_party.items()
               if ROSDEP_KEYS.get(name, name) not in declared}
    assert missing == {}
