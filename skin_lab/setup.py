"""Install skin_lab, the lab beside skin_driver (ament_python): bench, evaluator, demo."""

from setuptools import find_packages, setup

PACKAGE = 'skin_lab'

setup(
    name=PACKAGE,
    version='0.1.0',
    packages=find_packages(),
    package_data={PACKAGE: ['scenes/*.yaml']},
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + PACKAGE]),
        ('share/' + PACKAGE, ['package.xml']),
    ],
    install_requires=['setuptools'],
    zip_safe=True,
    maintainer='skin_driver maintainers',
    maintainer_email='skin-driver@example.com',
    description='The lab beside skin_driver: benchmark, evaluator, oracle, experiments, demo.',
    license='Apache-2.0',
    entry_points={
        'console_scripts': [
            'bench = skin_lab.bench.cli:main',
            'evaluate = skin_lab.evaluate.cli:main',
            'demo = skin_lab.demo:main',
        ],
    },
)
