"""
The core must run where no ROS is installed, and its wings keep one import rule.

No core module imports rclpy or a message package; ``estimation`` and ``sim`` never import each
other (the simulator is the truth the estimator is judged against); ``protocol`` imports
neither; ``common`` (checks, atomic writes) and ``robot`` (frames, mounts) import none of them.
"""

import ast
import pathlib
import subprocess
import sys

import pytest

CORE = pathlib.Path(__file__).resolve().parents[1] / 'skin_driver' / 'core'
# The ROS-free tools beside the core: the simulator, its export and the bag converter run
# without ROS too, and so does the lab's offline part (the evaluator, the experiments, the oracle
# and floor, the in-process benchmark).
ROS_FREE_TOOLS = ['skin_driver.tools.sim', 'skin_driver.tools.export',
                  'skin_driver.tools.bag_to_dataset', 'skin_lab.evaluate.cli',
                  'skin_lab.bench.estimators', 'skin_lab.experiments', 'skin_lab.oracle',
                  'skin_lab.floor']
FORBIDDEN = ('rclpy', 'rosidl', 'builtin_interfaces', 'std_msgs', 'geometry_msgs', 'sensor_msgs',
             'skin_msgs', 'visualization_msgs', 'diagnostic_msgs', 'std_srvs', 'launch')
# What each wing may not import (besides ROS).
WING_RULES = {'common': ('estimation', 'sim', 'protocol'), 'protocol': ('estimation', 'sim'),
              'estimation': ('sim', 'protocol'), 'sim': ('estimation',),
              'robot': ('estimation', 'sim', 'protocol')}


def _core_modules():
    return sorted(CORE.rglob('*.py'))


def _module_name(path):
    parts = path.relative_to(CORE.parents[1]).with_suffix('').parts
    return '.'.join(parts[:-1] if parts[-1] == '__init__' else parts)


def _imported_names(path):
    """Yield the absolute names of the modules ``path`` imports (relative ones resolved)."""
    package = _module_name(path).split('.')
    if path.name != '__init__.py':
        package = package[:-1]
    yield from _names_in(path.read_text(), package)


def _names_in(source, package):
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            yield from (alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = package[:len(package) - node.level + 1] if node.level else []
            module = '.'.join(base + ([node.module] if node.module else []))
            if node.module:
                yield module
            else:
                yield from (f'{module}.{alias.name}' for alias in node.names)


def _wing(name):
    parts = name.split('.')
    return parts[2] if parts[:2] == ['skin_driver', 'core'] and len(parts) > 2 else None


def test_core_has_three_wings():
    assert {_wing(_module_name(p)) for p in _core_modules()} - {None} == set(WING_RULES)


@pytest.mark.parametrize('path', _core_modules(), ids=lambda p: str(p.relative_to(CORE)))
def test_core_module_names_no_ros_import(path):
    bad = [name for name in _imported_names(path) if name.split('.')[0] in FORBIDDEN]
    assert bad == [], f'{path.name} imports {bad}'


@pytest.mark.parametrize('path', _core_modules(), ids=lambda p: str(p.relative_to(CORE)))
def test_wings_keep_the_import_rule(path):
    own = _wing(_module_name(path))
    if own is None:
        return
    bad = [name for name in _imported_names(path) if _wing(name) in WING_RULES[own]]
    assert bad == [], f'{own} module {path.name} imports {bad}'


def test_the_rule_checker_resolves_relative_imports():
    # A checker that missed relative imports could never fail on the core's own style.
    source = 'from ..sim import physics\nfrom .fsr import FsrModel\nfrom .. import sim\n'
    names = list(_names_in(source, ['skin_driver', 'core', 'estimation']))
    assert [_wing(n) for n in names] == ['sim', 'estimation', 'sim']


def test_importing_the_core_loads_no_ros_module():
    modules = [_module_name(p) for p in _core_modules()]
    code = (
        'import importlib, sys\n'
        f'for m in {modules + ROS_FREE_TOOLS!r}:\n'
        '    importlib.import_module(m)\n'
        f'bad = sorted(m for m in sys.modules if m.split(".")[0] in {FORBIDDEN!r})\n'
        'print(",".join(bad))\n'
    )
    out = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == ''


def test_importing_estimation_loads_no_sim_module():
    modules = [_module_name(p) for p in _core_modules() if _wing(_module_name(p)) == 'estimation']
    code = (
        'import importlib, sys\n'
        f'for m in {modules!r}:\n'
        '    importlib.import_module(m)\n'
        'print(",".join(sorted(m for m in sys.modules if m.startswith("skin_driver.core.sim"))))\n'
    )
    out = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == ''


def test_importing_the_simulator_loads_no_estimation_module():
    modules = [_module_name(p) for p in _core_modules() if _wing(_module_name(p)) == 'sim']
    assert 'skin_driver.core.sim.physics' in modules
    code = (
        'import importlib, sys\n'
        f'for m in {modules!r}:\n'
        '    importlib.import_module(m)\n'
        'print(",".join(sorted(m for m in sys.modules\n'
        '                      if m.startswith("skin_driver.core.estimation"))))\n'
    )
    out = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == ''
