"""
The direction node's estimator parameters as an :class:`EstimatorConfig`, without ROS.

The node and the evaluator both build their estimator here, so that one parameter file
(config/skin.yaml format) configures both alike.
"""

from __future__ import annotations

import os
from typing import Any, Mapping

from skin_driver.core.estimation.scan.pipeline import EstimatorConfig
import yaml

__all__ = ['ESTIMATOR_PARAMETERS', 'DIRECTION_NODE', 'estimator_config',
           'load_direction_parameters']

DIRECTION_NODE = 'skin_direction'
# Node parameter -> EstimatorConfig field; changing one at run time rebuilds the estimator.
ESTIMATOR_PARAMETERS = {
    'method': 'method', 'threshold': 'threshold_counts', 'min_force': 'min_contact_force_n',
    'min_confidence': 'min_confidence', 'min_shift': 'min_shift_m',
    'compliance': 'compliance_m_per_n', 'force_scale': 'force_scale',
    'skin.fill_factor': 'fill_factor',
}


def estimator_config(values: Mapping[str, Any], pitch_m: float) -> EstimatorConfig:
    """Return the config for node parameter ``values`` (missing ones keep the core default)."""
    fields = {ESTIMATOR_PARAMETERS[k]: v for k, v in values.items() if k in ESTIMATOR_PARAMETERS}
    return EstimatorConfig(pitch_m=pitch_m, **fields)


def _flatten(tree: Mapping, prefix: str = '') -> dict:
    """Return ROS's dotted names for nested parameter mappings (skin: {a: 1} -> skin.a)."""
    out = {}
    for key, value in tree.items():
        name = f'{prefix}{key}'
        if isinstance(value, Mapping):
            out.update(_flatten(value, name + '.'))
        else:
            out[name] = value
    return out


def load_direction_parameters(path: str | os.PathLike) -> dict:
    """
    Return the direction node's parameters from a ROS 2 parameter file.

    The file is a mapping of node names (``/**/skin_direction``, ``skin_direction``, any
    namespace) to ``{ros__parameters: {...}}``, like config/skin.yaml. ValueError names the
    problem: unreadable YAML, no section for the node, or an estimator parameter of the wrong
    kind.
    """
    try:
        with open(path) as f:
            data = yaml.safe_load(f)
    except (OSError, yaml.YAMLError) as err:
        raise ValueError(f'{os.fspath(path)}: cannot read parameters: {err}') from None
    if not isinstance(data, Mapping):
        raise ValueError(f'{os.fspath(path)}: not a mapping of node names')
    found = {}
    for node, section in data.items():
        if str(node).rstrip('/').split('/')[-1] != DIRECTION_NODE:
            continue
        params = section.get('ros__parameters') if isinstance(section, Mapping) else None
        if not isinstance(params, Mapping):
            raise ValueError(f'{os.fspath(path)}: {node}: needs a ros__parameters mapping')
        found.update(_flatten(params))
    if not found:
        raise ValueError(f'{os.fspath(path)}: no parameters for node {DIRECTION_NODE!r}')
    return found
