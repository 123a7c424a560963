"""package.xml declares every package the code and the tests import, so rosdep installs them."""

import ast
import pathlib
import sys
import xml.etree.ElementTree as ElementTree

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
# This project's own packages and the tests' helper modules.
OWN = {'skin_driver', 'skin_msgs', 'rosutil', 'pipeline', 'port_reader', 'conftest',
       'taxel_presses'}


def _imported_modules():
    modules = {}
    for folder in ('skin_driver', 'launch', 'test'):
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


def _declared():
    manifest = ElementTree.parse(ROOT / 'package.xml').getroot()
    return {element.text for element in manifest
            if element.tag.endswith('depend') and element.text}


def test_every_imported_package_is_declared_in_package_xml():
    third_party = {name: path for name, path in _imported_modules().items()
                   if name not in sys.stdlib_module_names and name not in OWN | PIP_ONLY}
    # matplotlib (the benchmark's tests plot) is the import a workstation lacked.
    assert 'matplotlib' in third_party
    declared = _declared()
    missing = {f'{name} (imported by {path})': ROSDEP_KEYS.get(name, name)
               for name, path in third_party.items()
               if ROSDEP_KEYS.get(name, name) not in declared}
    assert missing == {}
