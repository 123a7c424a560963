"""Install the skin_driver ROS 2 package (ament_python)."""

from glob import glob

from setuptools import find_packages, setup

PACKAGE = 'skin_driver'

setup(
    name=PACKAGE,
    version='0.1.0',
    packages=find_packages(exclude=['test']),
    package_data={PACKAGE: ['scenes/*.yaml', 'scenes/patches/*.yaml']},
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + PACKAGE]),
        ('share/' + PACKAGE, ['package.xml']),
        ('share/' + PACKAGE + '/launch', glob('launch/*.launch.py')),
        ('share/' + PACKAGE + '/config', glob('config/*.yaml') + glob('config/*.rviz')),
        ('share/' + PACKAGE + '/urdf', glob('urdf/*.xacro')),
    ],
    install_requires=['setuptools'],
    zip_safe=True,
    maintainer='skin_driver maintainers',
    maintainer_email='skin-driver@example.com',
    description='ROS 2 driver for a two-layer tactile skin with pressure direction detection.',
    license='Apache-2.0',
    tests_require=['pytest'],
    entry_points={
        'console_scripts': [
            'driver = skin_driver.ros.driver_node:main',
            'direction = skin_driver.ros.direction_node:main',
            'sim = skin_driver.tools.sim:main',
            'record = skin_driver.tools.record:main',
            'bag_to_dataset = skin_driver.tools.bag_to_dataset:main',
            'mount_tf = skin_driver.ros.frames:main',
            'patches = skin_driver.ros.patches_node:main',
            'patches_sim = skin_driver.tools.patches_sim:main',
            'bringup = skin_driver.tools.bringup.cli:main',
        ],
    },
)
