"""
Patches node: several skin patches as one skin, their contacts in one frame of the robot.

Subscribes to each patch's ``/<patch>/contacts`` (skin_msgs/TactileContactArray in the patch's
frame, sensor-data QoS) and, on every array that arrives, publishes

* ``contacts`` (TactileContactArray in ``common_frame``): the newest contacts of every patch
  heard from within ``max_age`` seconds, strongest first, each naming its patch (``patch``), with
  its location, force, layer shift and wrench carried into the common frame (the torque about the
  common frame's origin). Magnitude, normal force, azimuth, polar angle, their uncertainty, area
  and confidence stay as the patch measured them: they are taken against the patch's own surface.
  The header's stamp is the arriving array's; ``sequence`` counts this node's arrays (a
  subscriber counts lost ones by it) and ``device_time_us`` is 0 (no one board's clock);
* ``wrench/<link>`` (geometry_msgs/WrenchStamped in ``<link>``, one topic per parent link): the
  sum of the wrenches of that link's patches' contacts about the link's origin, as a
  force/torque sensor at the link's origin would report what its skin carries; zero when nothing
  touches it; same stamp as the ``contacts`` array published with it.

Where each patch is: its mount on its parent link (``<patch>.parent_frame``, ``.xyz``,
``.rpy``), the links' poses in the common frame (``links.<link>.xyz``, ``.rpy``: a robot that
does not move), and, where tf2_msgs is installed, /tf and /tf_static (a moving robot; a mount
published by the driver's launch file). Poses from the parameters win over /tf for the frames
they place; /tf places the rest, newest pose only. Without tf2_msgs the node says so once and
uses the parameters.

Everything runs on the executor, and nothing there waits: each array costs a few transforms and
one publish per topic. /diagnostics has, per patch, the age of its last array, whether its frame
is joined to the common frame (and if not, where the chain ends), and what was refused.
"""

import math
import time

from geometry_msgs.msg import Point, Vector3, Wrench, WrenchStamped
from rcl_interfaces.msg import ParameterDescriptor, SetParametersResult
import rclpy
from rclpy.exceptions import ParameterException
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from skin_driver.core.robot.patches import (carry_contact, check_frame_name, check_patch_name,
                                            FrameTree, parameter_prefix, Pose, sum_wrenches,
                                            UnknownTransform, vector3)
from skin_driver.ros import diagnostics, qos
from skin_driver.ros.frames import default_frame_id
from skin_driver.ros.lifetime import destroyed_if_refused
from skin_driver.ros.params import declare, ParameterError
from skin_driver.ros.spin import create_or_exit, spin_nodes
from skin_msgs.msg import TactileContact, TactileContactArray
from std_msgs.msg import Header

PARAMETERS = 'parameters'
TF_DEPTH = 100
MISSING_TF2_MSGS = ('tf2_msgs is not installed: link poses and mounts come from the parameters '
                    'alone, not from /tf or /tf_static (install ros-jazzy-tf2-msgs to follow a '
                    'moving robot)')


class _Patch:
    """What the node knows of one patch: where it is, what it last sent, what was refused."""

    def __init__(self, name: str, frame: str, topic: str):
        self.name, self.frame, self.topic = name, frame, topic
        self.prefix = parameter_prefix(name)
        self.received = None      # monotonic time of the last array
        self.arrays = self.contacts = self.refused = 0
        self.problem = ''         # why its last array was refused ('' when it was taken)
        self.taken = None         # (contacts in the common frame, link, link wrench)


class PatchesNode(Node):
    """Publish the contacts of several patches in one frame and the net wrench per link."""

    @destroyed_if_refused
    def __init__(self, **kwargs):
        """Create the node; a parameter it cannot work with raises ParameterError."""
        super().__init__('skin_patches', **kwargs)
        self._tree = FrameTree()
        self._declare_parameters()
        self._sequence = 0
        self._published = 0
        self._logged_once = set()
        self._link_pubs = {}
        quiet = qos.overridable()
        self._pub_contacts = self.create_publisher(TactileContactArray, 'contacts', qos.stream(),
                                                   **quiet)
        own = self.resolve_topic_name('contacts')
        for patch in self._patches.values():
            if patch.topic == own:
                raise self._refuse_start(
                    'patches', f'patch {patch.name!r} reads {patch.topic}, the topic this node '
                               'publishes: put the node in another namespace')
        for link in sorted({self._tree.parent_of(p.frame) for p in self._patches.values()}
                           - {None}):
            self._link_publisher(link)
        for patch in self._patches.values():
            self.create_subscription(
                TactileContactArray, patch.topic,
                lambda msg, patch=patch: self._on_contacts(patch, msg), qos.stream(), **quiet)
        self.transforms_from = self._listen_to_tf()
        self._diag = diagnostics.DiagnosticPublisher(self)
        self.create_timer(self.get_parameter('diagnostics_period').value, self._report)
        self.add_on_set_parameters_callback(self._check_new_parameters)
        self.add_post_set_parameters_callback(self._apply_new_parameters)
        self.get_logger().info(
            f'{len(self._patches)} patches ({", ".join(self._patches)}) in '
            f'{self._common}; poses from {self.transforms_from}')

    # ---- parameters ------------------------------------------------------------------------
    def _refuse_start(self, name: str, reason: str) -> ParameterError:
        err = ParameterError(f'parameter {name!r}: {reason}')
        err.logger_name = self.get_logger().name
        return err

    def _vector(self, name: str, default, description: str):
        """Declare a 3-vector parameter (integers taken too); return its floats or None."""
        descriptor = ParameterDescriptor(description=description, dynamic_typing=True)
        value = self.declare_parameter(name, default, descriptor).value
        if value is None:
            return None
        try:
            return vector3(list(value) if not isinstance(value, str) else value, name)
        except (TypeError, ValueError) as err:
            raise self._refuse_start(name, f'{err} ({description})') from None

    def _declare_parameters(self) -> None:
        self._common = declare(self, 'common_frame', 'base_link',
                               'The frame every contact is published in (the robot base).',
                               non_empty=True, read_only=True)
        try:
            check_frame_name(self._common, 'common_frame')
        except ValueError as err:
            raise self._refuse_start('common_frame', str(err)) from None
        try:
            names = self.declare_parameter(
                'patches', Parameter.Type.STRING_ARRAY, ParameterDescriptor(
                    description='Namespaces of the patches (their contacts: /<patch>/contacts).',
                    read_only=True)).value
        except ParameterException as err:
            raise self._refuse_start('patches', f'{err}; it takes a list of namespaces') from None
        if not names:
            raise self._refuse_start('patches', 'is not set; it takes the namespaces of the '
                                                'patches, e.g. [left, right]')
        self._patches = {}
        for raw in names:
            try:
                name = check_patch_name(raw)
            except ValueError as err:
                raise self._refuse_start('patches', str(err)) from None
            if name in self._patches:
                raise self._refuse_start('patches', f'{name!r} is named twice')
            prefix = parameter_prefix(name)
            frame = declare(self, f'{prefix}.frame_id', '',
                            f"Frame of {name}'s contacts (empty: from its namespace, as its "
                            'driver names it).', read_only=True) or default_frame_id(name)
            self._patches[name] = _Patch(name, frame, f'/{name}/contacts')
            parent = declare(self, f'{prefix}.parent_frame', '',
                             f'Link {name} is mounted on (empty: its mount comes from '
                             '/tf_static).', read_only=True)
            xyz = self._vector(f'{prefix}.xyz', [0.0, 0.0, 0.0],
                               f"{name}'s position on its parent link, metres.")
            rpy = self._vector(f'{prefix}.rpy', [0.0, 0.0, 0.0],
                               f"{name}'s fixed-axis roll, pitch, yaw on its parent link, rad.")
            if parent:
                try:
                    check_frame_name(parent, 'a parent frame')
                    self._tree.place(frame, parent, Pose.from_xyz_rpy(xyz, rpy), PARAMETERS, True)
                except ValueError as err:
                    raise self._refuse_start(f'{prefix}.parent_frame', str(err)) from None
        parents = {self._tree.parent_of(p.frame) for p in self._patches.values()}
        # Links named in the parameters given at start-up (a parameter file) as well as the
        # parents: a patch mounted through /tf_static may sit on a link placed here.
        given = {name.split('.')[1] for name in getattr(self, '_parameter_overrides', {})
                 if name.startswith('links.') and name.count('.') == 2}
        for link in sorted((parents | given) - {None, self._common}):
            try:
                check_frame_name(link, 'link')
            except ValueError as err:
                raise self._refuse_start(f'links.{link}', str(err)) from None
            xyz = self._vector(f'links.{link}.xyz', None,
                               f"{link}'s position in {self._common}, metres (unset: from /tf).")
            rpy = self._vector(f'links.{link}.rpy', None,
                               f"{link}'s fixed-axis roll, pitch, yaw in {self._common}, rad.")
            if xyz is not None or rpy is not None:
                self._place(link, self._common, xyz, rpy, f'links.{link}')
        declare(self, 'max_age', 0.2,
                'Seconds after its last array that a patch is left out of contacts and wrench.',
                low=0.001, high=60.0)
        declare(self, 'diagnostics_period', 1.0, 'Seconds between two /diagnostics reports.',
                low=0.1, high=60.0)
        declare(self, 'use_tf', True, 'Take link poses and mounts from /tf and /tf_static as '
                                      'well (needs tf2_msgs).', read_only=True)

    def _place(self, child, parent, xyz, rpy, name) -> None:
        try:
            pose = Pose.from_xyz_rpy(xyz or (0.0, 0.0, 0.0), rpy or (0.0, 0.0, 0.0))
            self._tree.place(child, parent, pose, PARAMETERS, True)
        except ValueError as err:
            raise self._refuse_start(name, str(err)) from None

    def _check_new_parameters(self, params) -> SetParametersResult:
        """Refuse a mount or link pose that is not three finite numbers."""
        for param in params:
            if param.name.endswith(('.xyz', '.rpy')):
                try:
                    vector3(list(param.value) if isinstance(param.value, (list, tuple))
                            or hasattr(param.value, 'tolist') else param.value, param.name)
                except (TypeError, ValueError) as err:
                    reason = f'{param.name} refused: {err}'
                    self.get_logger().warning(reason)
                    return SetParametersResult(successful=False, reason=reason)
        return SetParametersResult(successful=True)

    def _apply_new_parameters(self, params) -> None:
        """Put a new mount or link pose in force for the next arrays."""
        names = {param.name for param in params}
        for patch in self._patches.values():
            if {f'{patch.prefix}.xyz', f'{patch.prefix}.rpy'} & names:
                parent = self.get_parameter(f'{patch.prefix}.parent_frame').value
                if parent:
                    self._tree.place(patch.frame, parent, self._pose_of(patch.prefix),
                                     PARAMETERS, True)
                    self.get_logger().info(f'{patch.name} mount now {self._pose_text(patch)}')
        for name in names:
            parts = name.split('.')
            if parts[0] == 'links' and len(parts) == 3:
                self._tree.place(parts[1], self._common, self._pose_of(f'links.{parts[1]}'),
                                 PARAMETERS, True)
                self.get_logger().info(f'{parts[1]} now at a new pose in {self._common}')

    def _pose_of(self, prefix: str) -> Pose:
        values = []
        for key in ('xyz', 'rpy'):
            value = self.get_parameter(f'{prefix}.{key}').value
            values.append((0.0, 0.0, 0.0) if value is None else [float(v) for v in value])
        return Pose.from_xyz_rpy(*values)

    def _pose_text(self, patch: _Patch) -> str:
        xyz = self.get_parameter(f'{patch.prefix}.xyz').value
        rpy = self.get_parameter(f'{patch.prefix}.rpy').value
        return f'xyz {list(xyz)} rpy {list(rpy)}'

    # ---- /tf -------------------------------------------------------------------------------
    def _listen_to_tf(self) -> str:
        """Listen to /tf and /tf_static where tf2_msgs is installed; say where poses come from."""
        if not self.get_parameter('use_tf').value:
            return 'the parameters (use_tf false)'
        try:
            from tf2_msgs.msg import TFMessage
        except ImportError:
            self.get_logger().warning(MISSING_TF2_MSGS)
            return 'the parameters alone (tf2_msgs is not installed)'
        self.create_subscription(TFMessage, '/tf', lambda msg: self.on_tf(msg, '/tf'),
                                 QoSProfile(depth=TF_DEPTH,
                                            reliability=ReliabilityPolicy.RELIABLE))
        # /tf_static is latched: a mount published before this node started still arrives.
        self.create_subscription(TFMessage, '/tf_static',
                                 lambda msg: self.on_tf(msg, '/tf_static'),
                                 QoSProfile(depth=TF_DEPTH,
                                            reliability=ReliabilityPolicy.RELIABLE,
                                            durability=DurabilityPolicy.TRANSIENT_LOCAL))
        return 'the parameters, then /tf and /tf_static'

    def on_tf(self, msg, source: str) -> None:
        """Take the transforms of a tf2_msgs/TFMessage (or anything with its fields)."""
        for tf in msg.transforms:
            parent, child = tf.header.frame_id.lstrip('/'), tf.child_frame_id.lstrip('/')
            t, q = tf.transform.translation, tf.transform.rotation
            try:
                pose = Pose.from_quaternion((t.x, t.y, t.z), (q.x, q.y, q.z, q.w))
                if not self._tree.place(child, parent, pose, source):
                    self._once(f'kept {child}', f'{source} places {child} on {parent}; the pose '
                                                'the parameters give it is kept')
            except ValueError as err:
                self._once(f'refused {child}',
                           f'{source}: transform {parent} -> {child} refused: {err}', warn=True)

    def _once(self, key: str, text: str, warn: bool = False) -> None:
        if key not in self._logged_once:
            self._logged_once.add(key)
            (self.get_logger().warning if warn else self.get_logger().info)(text)

    # ---- contacts --------------------------------------------------------------------------
    def _link_publisher(self, link: str):
        pub = self._link_pubs.get(link)
        if pub is None:
            pub = self._link_pubs[link] = self.create_publisher(
                WrenchStamped, f'wrench/{link}', qos.stream(), **qos.overridable())
        return pub

    def _refuse(self, patch: _Patch, reason: str) -> None:
        patch.refused += 1
        patch.taken = None
        if reason != patch.problem:  # a new reason is told at once, a repeated one every 5 s
            self.get_logger().warning(f'{patch.name}: contacts refused: {reason}')
        else:
            self.get_logger().warning(f'{patch.name}: contacts refused: {reason}',
                                      throttle_duration_sec=5.0)
        patch.problem = reason

    def _on_contacts(self, patch: _Patch, msg: TactileContactArray) -> None:
        patch.received = time.monotonic()
        patch.arrays += 1
        if msg.header.frame_id != patch.frame:
            self._refuse(patch, f'they are in frame {msg.header.frame_id!r}, not the patch '
                                f'frame {patch.frame!r} (parameter {patch.prefix}.frame_id)')
        else:
            try:
                patch.taken = self._carry(patch, msg)
                patch.contacts += len(msg.contacts)
                patch.problem = ''
            except (UnknownTransform, ValueError) as err:
                self._refuse(patch, str(err))
        self._publish(msg.header.stamp)

    def _carry(self, patch: _Patch, msg: TactileContactArray) -> tuple:
        """Return (contacts in the common frame, link, link wrench) of one patch's array."""
        link = self._tree.parent_of(patch.frame)
        if link is None:
            raise UnknownTransform(
                f'{patch.frame} has no mount: set {patch.prefix}.parent_frame (and .xyz, .rpy) '
                'or publish it on /tf_static')
        check_frame_name(link, 'its link')
        to_common = self._tree.pose(self._common, patch.frame)
        to_link = self._tree.pose(link, patch.frame)
        header = Header(stamp=msg.header.stamp, frame_id=self._common)
        out, wrenches = [], []
        for c in msg.contacts:
            location = (c.location.x, c.location.y, c.location.z)
            shift = (c.shift.x, c.shift.y, c.shift.z)
            force = (c.wrench.force.x, c.wrench.force.y, c.wrench.force.z)
            torque = (c.wrench.torque.x, c.wrench.torque.y, c.wrench.torque.z)
            values = location + shift + force + torque
            if not all(math.isfinite(v) for v in values):
                raise ValueError('a contact holds a value that is not finite')
            loc, sh, f, t = carry_contact(to_common, location, shift, force, torque)
            wrenches.append(to_link.wrench(force, torque))
            out.append(TactileContact(
                header=header, location=Point(x=loc[0], y=loc[1], z=loc[2]),
                magnitude=c.magnitude, normal_force=c.normal_force, azimuth=c.azimuth,
                azimuth_sigma=c.azimuth_sigma, polar=c.polar,
                shift=Vector3(x=sh[0], y=sh[1], z=sh[2]),
                wrench=Wrench(force=Vector3(x=f[0], y=f[1], z=f[2]),
                              torque=Vector3(x=t[0], y=t[1], z=t[2])),
                area=c.area, confidence=c.confidence, direction_valid=c.direction_valid,
                held=c.held, patch=patch.name))
        self._link_publisher(link)
        return out, link, sum_wrenches(wrenches)

    def _publish(self, stamp) -> None:
        """Publish every fresh patch's contacts and every link's net wrench, at ``stamp``."""
        now = time.monotonic()
        max_age = self.get_parameter('max_age').value
        fresh = [p.taken for p in self._patches.values()
                 if p.taken is not None and now - p.received <= max_age]
        contacts = sorted((c for taken in fresh for c in taken[0]),
                          key=lambda c: c.magnitude, reverse=True)
        self._pub_contacts.publish(TactileContactArray(
            header=Header(stamp=stamp, frame_id=self._common), sequence=self._sequence,
            device_time_us=0, contacts=contacts))
        self._sequence = (self._sequence + 1) & 0xFFFFFFFF
        self._published += 1
        for link, pub in self._link_pubs.items():
            force, torque = sum_wrenches(taken[2] for taken in fresh if taken[1] == link)
            pub.publish(WrenchStamped(header=Header(stamp=stamp, frame_id=link), wrench=Wrench(
                force=Vector3(x=force[0], y=force[1], z=force[2]),
                torque=Vector3(x=torque[0], y=torque[1], z=torque[2]))))

    # ---- diagnostics -----------------------------------------------------------------------
    def statuses(self) -> list:
        """Return the node's diagnostic statuses: one for the node, one per patch."""
        now = time.monotonic()
        max_age = self.get_parameter('max_age').value
        name = self.get_fully_qualified_name()
        out = [diagnostics.make_status(
            f'{name}: patches', self._common, diagnostics.OK,
            f'{len(self._patches)} patches in {self._common}',
            {'common frame': self._common, 'patches': ', '.join(self._patches),
             'links': ', '.join(sorted(self._link_pubs)), 'poses from': self.transforms_from,
             'arrays published': self._published})]
        for patch in self._patches.values():
            link = self._tree.parent_of(patch.frame)
            if link is None:
                transform = (f'{patch.frame} has no mount (set {patch.prefix}.parent_frame or '
                             'publish it on /tf_static)')
            else:
                try:
                    self._tree.pose(self._common, patch.frame)
                    transform = 'known'
                except UnknownTransform as err:
                    transform = str(err)
            age = None if patch.received is None else now - patch.received
            level, message = diagnostics.OK, 'contacts arriving'
            if transform != 'known':
                level, message = diagnostics.ERROR, f'unknown transform: {transform}'
            elif patch.problem:
                level, message = diagnostics.ERROR, f'contacts refused: {patch.problem}'
            elif age is None:
                level, message = diagnostics.WARN, f'no contacts received yet on {patch.topic}'
            elif age > max_age:
                level, message = diagnostics.WARN, (f'no contacts for {age:.1f} s: left out '
                                                    f'(max_age {max_age:g} s)')
            out.append(diagnostics.make_status(
                f'{name}: patch {patch.name}', patch.frame, level, message,
                {'topic': patch.topic, 'frame': patch.frame, 'link': link or 'unknown',
                 'mount from': self._tree.source_of(patch.frame) or 'nowhere yet',
                 'last contacts age [s]': 'none yet' if age is None else age,
                 'transform to common frame': transform, 'arrays': patch.arrays,
                 'contacts': patch.contacts, 'arrays refused': patch.refused,
                 'last refusal': patch.problem or 'none'}))
        return out

    def _report(self) -> None:
        self._diag.publish(self.statuses())


def main(args=None):
    """Run the patches node until shut down."""
    rclpy.init(args=args)
    spin_nodes([create_or_exit(PatchesNode, 'skin_patches')])


if __name__ == '__main__':
    main()
