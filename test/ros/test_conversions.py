"""Message conversions: faithful, and never a NaN or inf in a message."""

import math

from builtin_interfaces.msg import Time
from geometry_msgs.msg import WrenchStamped
import numpy as np
import pytest
from rclpy.serialization import deserialize_message, serialize_message
from skin_driver.core.estimation.scan.heatmap import grey_levels
from skin_driver.core.estimation.scan.pipeline import Contact, ContactEstimator, EstimatorConfig
from skin_driver.core.sim.physics import Press, render, SkinModel
from skin_driver.ros import conversions
from skin_msgs.msg import SkinFrame, TactileContact, TactileContactArray
from std_msgs.msg import Header
from visualization_msgs.msg import Marker, MarkerArray

HEADER = Header(frame_id='skin_link')


def _contact(**changes):
    values = {'x_m': 0.03, 'y_m': 0.04, 'force_n': 7.0, 'area_m2': 5e-5, 'shift_m': (0.0, 0.002),
              'azimuth_rad': math.pi / 2, 'azimuth_sigma_rad': 0.05, 'alpha_rad': math.pi / 4,
              'force_xyz_n': (0.0, 7.0, -7.0), 'confidence': 0.9, 'direction_valid': True}
    values.update(changes)
    return Contact(**values)


def test_contact_message_carries_every_field():
    msg = conversions.contact_to_msg(HEADER, _contact())
    assert (msg.location.x, msg.location.y, msg.location.z) == (0.03, 0.04, 0.0)
    # |F| of a 45 degree push with 7 N into the skin; the normal part on its own.
    assert msg.magnitude == pytest.approx(7.0 * math.sqrt(2.0)) and msg.normal_force == 7.0
    assert msg.confidence == 0.9 and msg.azimuth == pytest.approx(math.pi / 2)
    assert msg.polar == pytest.approx(math.pi / 4) and msg.direction_valid
    assert msg.azimuth_sigma == 0.05
    assert (msg.wrench.force.y, msg.wrench.force.z) == (7.0, -7.0)
    assert msg.shift.y == 0.002 and msg.header.frame_id == 'skin_link'


def test_a_contact_without_a_direction_arrives_as_the_core_made_it():
    # A normal press: the core finds no direction and says what that looks like (Contact).
    model = SkinModel(noise_counts=0.0)
    top, bottom = render(model, [Press(0.0377, 0.0391, 10.0, radius_m=0.004)],
                         np.random.default_rng(0))
    (contact,) = ContactEstimator(EstimatorConfig(pitch_m=model.pitch_m)).process(top, bottom)
    assert not contact.direction_valid
    msg = conversions.contact_to_msg(HEADER, contact)
    assert (msg.azimuth, msg.azimuth_sigma, msg.polar, msg.direction_valid) == (
        contact.azimuth_rad, contact.azimuth_sigma_rad, contact.alpha_rad, False)
    assert (msg.azimuth, msg.azimuth_sigma, msg.polar) == (0.0, math.pi, 0.0)
    assert (msg.wrench.force.x, msg.wrench.force.y) == (0.0, 0.0)


@pytest.mark.parametrize('field,value', [('force_n', math.nan), ('x_m', math.inf),
                                         ('force_xyz_n', (0.0, math.nan, -1.0)),
                                         ('shift_m', (math.inf, 0.0))])
def test_a_non_finite_value_is_refused_not_published(field, value):
    with pytest.raises(ValueError, match='never carries NaN or inf'):
        conversions.contact_to_msg(HEADER, _contact(**{field: value}))


def test_layer_images_are_mono16_little_endian_rows_first():
    counts = np.arange(6, dtype=np.uint16).reshape(2, 3) * 1000
    image = conversions.counts_to_image(HEADER, counts)
    assert (image.height, image.width, image.step, image.encoding) == (2, 3, 6, 'mono16')
    assert np.array_equal(np.frombuffer(bytes(image.data), '<u2').reshape(2, 3), counts)


def test_skin_frame_with_wrong_sizes_is_refused():
    msg = conversions.skin_frame_to_msg(HEADER, 1, 2, 0.005, np.zeros((4, 4), np.uint16),
                                        np.zeros((4, 4), np.uint16))
    msg.rows = 5
    with pytest.raises(ValueError, match='expected 20 each'):
        conversions.skin_frame_layers(msg)


def test_markers_draw_grid_arrow_and_label_per_contact():
    force = np.zeros((16, 16))
    force[8, 6] = 5.0
    markers = conversions.heatmap_markers(HEADER, force, 0.005, [_contact()], 10.0).markers
    assert markers[0].action == Marker.DELETEALL
    grid = markers[1]
    assert grid.type == Marker.CUBE_LIST and len(grid.points) == 256 == len(grid.colors)
    hot = grid.colors[8 * 16 + 6]
    assert hot.r > grid.colors[0].r
    arrow, label = markers[2], markers[3]
    assert arrow.type == Marker.ARROW and (arrow.points[1].x, arrow.points[1].y) == (0.03, 0.04)
    # The arrow comes from where the push comes from: against +y, above the skin.
    assert arrow.points[0].y < 0.04 and arrow.points[0].z > 0
    assert label.text == '7.0 N β 90°'


def _vec(v):
    return np.array([v.x, v.y, v.z])


def test_contact_wrench_torque_is_the_force_moment_about_the_frame_origin():
    msg = conversions.contact_to_msg(HEADER, _contact())
    r = _vec(msg.location)
    assert _vec(msg.wrench.torque) == pytest.approx(np.cross(r, (0.0, 7.0, -7.0)))
    # About the contact point itself the wrench is a pure force, as it physically is.
    assert _vec(msg.wrench.torque) - np.cross(r, _vec(msg.wrench.force)) == pytest.approx(0.0)


def test_wrench_stamped_carries_the_torque_of_the_force_at_its_point():
    one = _contact(x_m=0.02, y_m=0.01, force_xyz_n=(1.0, -2.0, -5.0))
    stamped = conversions.wrench_stamped(HEADER, [one])
    assert _vec(stamped.wrench.force) == pytest.approx((1.0, -2.0, -5.0))
    assert _vec(stamped.wrench.torque) == pytest.approx(
        np.cross((0.02, 0.01, 0.0), (1.0, -2.0, -5.0)))
    nothing = conversions.wrench_stamped(HEADER, [])
    assert _vec(nothing.wrench.force) == pytest.approx(0.0)
    assert _vec(nothing.wrench.torque) == pytest.approx(0.0)


def test_the_wrench_of_a_pinch_is_the_net_of_both_fingers_as_an_ft_sensor_reports_it():
    # Two fingers pushing towards each other along x, both pressing 5 N into the skin.
    left = _contact(x_m=0.02, y_m=0.04, force_xyz_n=(3.0, 0.0, -5.0), force_n=5.0)
    right = _contact(x_m=0.06, y_m=0.04, force_xyz_n=(-3.0, 0.0, -5.0), force_n=5.0)
    net = conversions.wrench_stamped(HEADER, [left, right]).wrench
    # Tangential forces cancel; the normal ones add; torques about the origin sum.
    assert _vec(net.force) == pytest.approx((0.0, 0.0, -10.0))
    expected = (np.cross((0.02, 0.04, 0.0), (3.0, 0.0, -5.0))
                + np.cross((0.06, 0.04, 0.0), (-3.0, 0.0, -5.0)))
    assert _vec(net.torque) == pytest.approx(expected)


def test_a_reused_array_carries_each_scan_exactly_as_a_new_one_would():
    writer = conversions.ContactArrayWriter()
    two = [_contact(), _contact(x_m=0.01, direction_valid=False, force_n=3.0)]
    first = writer.fill(HEADER, two, sequence=2 ** 32 + 5, device_time_us=7)
    assert first == conversions.contacts_to_array(HEADER, two, 5, 7)
    assert first.sequence == 5 and len(first.contacts) == 2
    one = [_contact(y_m=0.02, azimuth_rad=-1.0)]
    second = writer.fill(HEADER, one, sequence=6, device_time_us=8)
    assert second == conversions.contacts_to_array(HEADER, one, 6, 8)
    assert writer.fill(HEADER, [], 7, 9).contacts == []


@pytest.mark.parametrize('frame_id', ['', 's', 'skin_link', 'left_skin_link', 'arm/skin_ä'])
def test_serialized_messages_read_back_as_the_messages_they_stand_for(frame_id):
    serialized = conversions.SerializedMessages(frame_id)
    assert serialized.usable
    header = Header(stamp=Time(sec=12, nanosec=345), frame_id=frame_id)
    # Three contacts: each starts at another offset, so each gets other padding.
    contacts = [_contact(), _contact(x_m=0.01, direction_valid=False, force_n=3.0),
                _contact(y_m=0.02, azimuth_rad=-1.0, force_xyz_n=(1.0, -2.0, -4.0))]
    for count in range(len(contacts) + 1):
        some = contacts[:count]
        fields = [conversions.contact_fields(c) for c in some]
        array = deserialize_message(serialized.contacts(12, 345, 2 ** 32 + 6, 2 ** 40, fields),
                                    TactileContactArray)
        assert array == conversions.contacts_to_array(header, some, 6, 2 ** 40)
        wrench = deserialize_message(serialized.wrench(12, 345, some), WrenchStamped)
        assert wrench == conversions.wrench_stamped(header, some)
    contact = deserialize_message(serialized.contact(12, 345, fields[2]), TactileContact)
    assert contact == conversions.contact_to_msg(header, contacts[2])


def test_contact_fields_refuse_what_a_message_never_carries():
    with pytest.raises(ValueError, match='NaN or inf'):
        conversions.contact_fields(_contact(x_m=math.nan))


@pytest.mark.parametrize('shape', [(16, 16), (3, 5), (1, 1)])
def test_a_serialized_skin_frame_reads_back_as_the_message(shape):
    serialized = conversions.SerializedMessages('left_skin_link')
    rng = np.random.default_rng(3)
    top, bottom = (rng.integers(0, 4096, shape).astype(np.uint16) for _ in range(2))
    header = Header(stamp=Time(sec=3, nanosec=4), frame_id='left_skin_link')
    frame = deserialize_message(serialized.frame(3, 4, 2 ** 32 + 9, 77, 0.005, top, bottom),
                                SkinFrame)
    assert frame == conversions.skin_frame_to_msg(header, 9, 77, frame.pitch, top, bottom)
    assert frame.pitch == pytest.approx(0.005)
    np.testing.assert_array_equal(conversions.skin_frame_layers(frame)[1], bottom)


@pytest.mark.parametrize('shape', [(16, 16), (3, 5), (1, 1)])
def test_grid_markers_as_bytes_read_back_as_the_markers_they_stand_for(shape):
    grid = conversions.GridMarkers('left_skin_link', shape, 0.004)
    assert grid.usable
    force = np.random.default_rng(5).uniform(0.0, 12.0, shape)
    header = Header(stamp=Time(sec=8, nanosec=9), frame_id='left_skin_link')
    markers = deserialize_message(grid.serialize(8, 9, grey_levels(force, 10.0)), MarkerArray)
    assert markers == MarkerArray(markers=conversions.grid_markers(header, force, 0.004, 10.0))
    assert markers == MarkerArray(markers=conversions.heatmap_markers(
        header, force, 0.004, [], 10.0).markers)


def test_skin_frame_bytes_are_read_into_the_scans_layers():
    assert conversions.skin_frames_read_back()
    rng = np.random.default_rng(4)
    top, bottom = (rng.integers(0, 4096, (3, 5)).astype(np.uint16) for _ in range(2))
    header = Header(stamp=Time(sec=3, nanosec=4), frame_id='arm/skin_ä')
    data = serialize_message(conversions.skin_frame_to_msg(header, 9, 77, 0.0078125, top,
                                                           bottom))
    got = conversions.read_skin_frame(data)
    assert got[:4] == (header, 9, 77, 0.0078125)
    np.testing.assert_array_equal(got[4], top)
    np.testing.assert_array_equal(got[5], bottom)
    assert not got[4].flags.writeable


def test_skin_frame_bytes_of_another_grid_or_cut_short_are_refused():
    header = Header(stamp=Time(sec=3, nanosec=4), frame_id='skin_link')
    msg = conversions.skin_frame_to_msg(header, 1, 2, 0.005, np.zeros((4, 4), np.uint16),
                                        np.zeros((4, 4), np.uint16))
    msg.rows = 5
    with pytest.raises(ValueError, match='expected 20 each'):
        conversions.read_skin_frame(serialize_message(msg))
    msg.rows = 4
    with pytest.raises(ValueError, match='not a whole SkinFrame'):
        conversions.read_skin_frame(serialize_message(msg)[:60])


@pytest.mark.parametrize('frame_id', ['', 'skin_link', 'arm/skin_ä'])
@pytest.mark.parametrize('count', [0, 1, 3])
def test_the_head_of_contacts_bytes_is_read_without_the_contacts(frame_id, count):
    # Every frame_id length pads the fields after it differently.
    msg = TactileContactArray(header=Header(stamp=Time(sec=-3, nanosec=4), frame_id=frame_id),
                              sequence=2 ** 32 - 1, device_time_us=2 ** 40 + 5,
                              contacts=[TactileContact() for _ in range(count)])
    data = serialize_message(msg)
    assert conversions.read_contacts_head(data) == (-3, 4, 2 ** 32 - 1, 2 ** 40 + 5, count)
    with pytest.raises(ValueError, match='not a TactileContactArray'):
        conversions.read_contacts_head(data[:20])
