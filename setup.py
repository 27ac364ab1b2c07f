"""ament_python build of steer_monitor; also installs with pip into a virtual environment."""

from glob import glob

from setuptools import find_packages, setup

PACKAGE = 'steer_monitor'

setup(
    name=PACKAGE,
    version='0.1.0',
    packages=find_packages(include=[PACKAGE, f'{PACKAGE}.*']),
    package_data={f'{PACKAGE}._vendor.mcap': ['LICENSE', 'py.typed']},
    data_files=[
        ('share/ament_index/resource_index/packages', [f'resource/{PACKAGE}']),
        (f'share/{PACKAGE}', ['package.xml', 'LICENSE']),
        (f'share/{PACKAGE}/config', sorted(glob('config/*.yaml') + glob('config/*.dbc'))),
        (f'share/{PACKAGE}/config/aggregator', sorted(glob('config/aggregator/*.yaml'))),
        (f'share/{PACKAGE}/launch', sorted(glob('launch/*.launch.py'))),
        (f'share/{PACKAGE}/systemd', sorted(glob('systemd/*.service'))),
    ],
    python_requires='>=3.10',
    install_requires=[
        'setuptools',
        'numpy>=1.24',
        'numba>=0.59',
        'scipy>=1.10',
        'PyYAML>=6',
        'ruamel.yaml>=0.17',
        'matplotlib>=3.7',
        'tqdm>=4.60',
        'python-can>=4.3',
        'zstandard>=0.21',
        'lz4>=4',
        'threadpoolctl>=3.1',
    ],
    zip_safe=True,
    maintainer='steer_monitor maintainers',
    maintainer_email='steer-monitor@example.com',
    description='Condition monitor for ram-type hydraulic steering gear (ROS 2).',
    license='Apache-2.0',
    # ashore only (steer-monitor fleet), not the node's: Dask distributed and Parquet
    extras_require={
        'test': ['pytest', 'hypothesis', 'rosbags', 'cantools>=39', 'mcap>=1.6'],
        'ashore': ['dask[distributed]>=2024.1', 'pyarrow>=14', 'mcap-ros2-support>=0.5'],
    },
    entry_points={
        'console_scripts': [
            'steer-monitor = steer_monitor.cli.main:main',
            'monitor = steer_monitor.node.monitor_node:main',
        ],
    },
)
