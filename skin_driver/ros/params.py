"""
Declare node parameters with descriptions and ranges, and fail with one clear message.

rclpy checks ranges itself when a value is set; these helpers add the description, turn a value
out of range at start-up into a ParameterError that names the parameter, its value and what it
accepts, and check the constraints that a range cannot express (choices, non-empty strings).

A parameter that takes a double takes a whole number too, as a user writes it (``threshold:=40``,
``threshold: 40`` in YAML, ``ros2 param set ... threshold 60``): it is stored as the double.
rclpy would refuse it as of the wrong type.
"""

import re
from typing import Any, Optional, Sequence

from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor, ParameterType
from rclpy.exceptions import InvalidParameterValueException, ParameterException
import rclpy.logging
from rclpy.parameter import Parameter


class ParameterError(ValueError):
    """A parameter has a value the node cannot work with."""

    # The logger of the node that refused it (its namespace and name), once declare() knows it.
    logger_name = ''

    def log_fatal(self, fallback: str) -> None:
        """Log this error as fatal under the node's own logger, e.g. [left.skin_direction]."""
        rclpy.logging.get_logger(self.logger_name or fallback).fatal(str(self))


def declare(node, name: str, default: Any, description: str, *,
            low: Optional[float] = None, high: Optional[float] = None,
            choices: Optional[Sequence[str]] = None, read_only: bool = False,
            non_empty: bool = False) -> Any:
    """Declare one parameter and return its validated value."""
    try:
        return _declare(node, name, default, description, low=low, high=high, choices=choices,
                        read_only=read_only, non_empty=non_empty)
    except ParameterError as err:
        err.logger_name = node.get_logger().name
        raise


def _declare(node, name: str, default: Any, description: str, *, low, high, choices, read_only,
             non_empty) -> Any:
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
    override = _whole_number_override(node, name) if isinstance(default, float) else None
    try:
        if override is None:
            value = node.declare_parameter(name, default, descriptor).value
        else:
            value = node.declare_parameter(name, float(override), descriptor,
                                           ignore_override=True).value
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


def _whole_number_override(node, name: str) -> Optional[int]:
    """Return the start-up value of ``name`` when it is an integer, else None."""
    # rclpy keeps the command line's and the YAML file's values here, and offers no public view.
    given = getattr(node, '_parameter_overrides', {}).get(name)
    return given.value if given is not None and given.type_ == Parameter.Type.INTEGER else None


def accept_whole_numbers(node) -> None:
    """Let ``node`` take an integer for any of its double parameters when one is set."""
    def as_doubles(parameters):
        out = []
        for param in parameters:
            if (param.type_ == Parameter.Type.INTEGER and node.has_parameter(param.name)
                    and node.describe_parameter(param.name).type
                    == ParameterType.PARAMETER_DOUBLE):
                param = Parameter(param.name, Parameter.Type.DOUBLE, float(param.value))
            out.append(param)
        return out
    node.add_pre_set_parameters_callback(as_doubles)
