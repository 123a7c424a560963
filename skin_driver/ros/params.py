"""
Declare node parameters with descriptions and ranges, and fail with one clear message.

rclpy checks ranges itself when a value is set; these helpers add the description, turn a value
out of range at start-up into a ParameterError that names the parameter, its value and what it
accepts, and check the constraints that a range cannot express (choices, non-empty strings).
"""

import re
from typing import Any, Optional, Sequence

from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor
from rclpy.exceptions import InvalidParameterValueException, ParameterException


class ParameterError(ValueError):
    """A parameter has a value the node cannot work with."""


def declare(node, name: str, default: Any, description: str, *,
            low: Optional[float] = None, high: Optional[float] = None,
            choices: Optional[Sequence[str]] = None, read_only: bool = False,
            non_empty: bool = False) -> Any:
    """Declare one parameter and return its validated value."""
    descriptor = ParameterDescriptor(description=description, read_only=read_only)
    accepts = ''
    if low is not None and high is not None:
        if isinstance(default, bool):
            raise TypeError(f'{name}: a range makes no sense for a bool')
        if isinstance(default, int):
            descriptor.integer_range = [IntegerRange(from_value=int(low), to_value=int(high),
                                                     step=0)]
        else:
            descriptor.floating_point_range = [FloatingPointRange(
                from_value=float(low), to_value=float(high), step=0.0)]
        accepts = f'a value in [{low}, {high}]'
    if choices:
        descriptor.additional_constraints = 'one of: ' + ', '.join(choices)
        accepts = descriptor.additional_constraints
    try:
        value = node.declare_parameter(name, default, descriptor).value
    except InvalidParameterValueException as err:
        found = re.search(r'value: (\S+?):? ', str(err) + ' ')
        value = found.group(1) if found else 'given'
        raise ParameterError(f'parameter {name!r} = {value} is out of range: it takes {accepts} '
                             f'({description})') from None
    except ParameterException as err:
        raise ParameterError(f'parameter {name!r}: {err} ({description})') from None
    check(name, value, description, choices=choices, non_empty=non_empty)
    return value


def check(name: str, value: Any, description: str, *,
          choices: Optional[Sequence[str]] = None, non_empty: bool = False) -> None:
    """Raise ParameterError unless value is one of choices and, if asked, not empty."""
    if choices and value not in choices:
        raise ParameterError(f'parameter {name!r} is {value!r}; it takes one of '
                             f'{", ".join(choices)} ({description})')
    if non_empty and not str(value).strip():
        raise ParameterError(f'parameter {name!r} is empty; it needs {description}')
