"""
Conversions between the ROS-free core's values and ROS messages, kept in one place.

No node lives here (as in sensor_msgs_py): everything takes and returns plain values and messages,
so the nodes stay thin and the conversions can be tested without a running ROS graph. Message
objects: :mod:`.messages`; the hot path's messages as CDR bytes: :mod:`.cdr`.
"""

from .cdr import (GridMarkers, read_contacts_head, read_skin_frame, SerializedMessages,
                  skin_frames_read_back)
from .messages import (
    calibration_feedback, contact_fields, contact_markers, contact_to_msg, ContactArrayWriter,
    contacts_to_array, counts_to_image, fill_compliance_result, fill_direction_result,
    fill_force_result,
    fill_gains_result, fill_offset_result, frame_pitch, grid_markers, heatmap_markers,
    make_header,
    mount_pose, mount_transform, rgb_to_image, skin_frame_layers, skin_frame_to_msg, status_values,
    wrench_stamped)

__all__ = [
    'calibration_feedback', 'contact_fields', 'contact_markers', 'contact_to_msg',
    'ContactArrayWriter', 'contacts_to_array', 'counts_to_image', 'fill_compliance_result',
    'fill_direction_result', 'fill_force_result', 'fill_gains_result', 'fill_offset_result',
    'frame_pitch', 'grid_markers',
    'GridMarkers', 'heatmap_markers', 'make_header',
    'mount_pose', 'mount_transform', 'read_contacts_head', 'read_skin_frame', 'rgb_to_image',
    'SerializedMessages',
    'skin_frame_layers', 'skin_frame_to_msg', 'skin_frames_read_back', 'status_values',
    'wrench_stamped']
