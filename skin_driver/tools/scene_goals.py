"""
The calibration goals a scene's labelled presses answer, as `ros2 action send_goal` commands.

A press labelled ``offset``, ``force``, ``compliance``, ``gains``, ``direction``, ``mount`` or
``creep`` is one of that calibration's presses (skin_driver/scenes/calibrate.yaml). The goals
are read from the scene itself: its loads, tilts, azimuths, touch points (``mount``) and held
load, so a scene written by hand tells its goals too (``sim --scene FILE --goals``).
"""

import math

__all__ = ['scene_goals', 'LABELS']

# label: (action under skin_direction, its type)
LABELS = {'offset': ('calibrate', 'Calibrate'), 'force': ('calibrate_force', 'CalibrateForce'),
          'compliance': ('calibrate_compliance', 'CalibrateCompliance'),
          'gains': ('calibrate_gains', 'CalibrateGains'),
          'direction': ('calibrate_direction', 'CalibrateDirection'),
          'mount': ('calibrate_mount', 'CalibrateMount'),
          'creep': ('calibrate_creep', 'CalibrateCreep')}
# Seconds a goal waits beyond its presses: time to send it before the first one.
SLACK_S = 30.0


def _number(value: float) -> str:
    """Return a float as YAML that stays a float (the goals' fields are float64)."""
    return repr(round(float(value), 4))


def _numbers(values) -> str:
    return '[' + ', '.join(_number(v) for v in values) + ']'


def _goal(scene, label: str, presses: list) -> str:
    """Return the goal's YAML (without timeout) for one label's presses."""
    if label in ('offset', 'gains'):
        return f'presses: {len(presses)}'
    if label == 'force':
        return f'forces: {_numbers(p.force_n for p in presses)}'
    if label == 'compliance':
        return (f'forces: {_numbers(p.force_n for p in presses)}, alphas: '
                f'{_numbers(math.radians(p.alpha_deg) for p in presses)}')
    if label == 'direction':
        return 'azimuths: ' + _numbers(math.radians(p.beta_deg) % math.tau for p in presses)
    if label == 'mount':
        points = ', '.join('{x: %s, y: %s, z: %s}' % tuple(_number(v) for v in p)
                           for p in scene.mount_points())
        return f'points: [{points}]'
    held = presses[0]
    # The hold asked for: what the load stays at full force, less a little for its arrival.
    hold = 10.0 * math.floor((held.duration_s - 2.0 * held.ramp_s - 2.0) / 10.0)
    goal = f'load: {_number(held.force_n)}, hold: {_number(max(hold, 5.0))}'
    if len(presses) > 1:
        goal += f', rest: {_number(presses[1].time_s - held.end_s)}'
    return goal


def scene_goals(scene, namespace: str = '/skin') -> list:
    """
    Return (start s, label, command) of each calibration the scene plays, by their first press.

    ``namespace`` is the driver's (the launch file's, ``/skin`` by default). A scene with
    presses labelled ``mount`` and no ``mount`` key raises ValueError.
    """
    prefix = '/' + '/'.join(part for part in namespace.split('/') if part)
    goals = []
    for label, (action, kind) in LABELS.items():
        presses = scene.labelled(label)
        if not presses:
            continue
        span = max(p.end_s for p in presses) - presses[0].time_s
        timeout = SLACK_S * math.ceil((span + SLACK_S) / SLACK_S)
        goal = '{' + _goal(scene, label, presses) + f', timeout: {_number(timeout)}' + '}'
        where = f'{prefix}/skin_direction/{action}'.replace('//', '/')
        goals.append((presses[0].time_s, label,
                      f'ros2 action send_goal --feedback {where} skin_msgs/action/{kind} '
                      f'"{goal}"'))
    return sorted(goals)
