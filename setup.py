from glob import glob

from setuptools import find_packages, setup

package_name = 'formation_control'

setup(
    name=package_name,
    version='0.1.0',
    packages=find_packages(exclude=['test']),
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + package_name]),
        ('share/' + package_name, ['package.xml']),
        ('share/' + package_name + '/config', glob('config/*.yaml')),
    ],
    install_requires=['setuptools', 'numpy', 'pyyaml', 'matplotlib', 'rosbags'],
    extras_require={'test': ['pytest']},
    zip_safe=True,
    maintainer='formation_control developers',
    maintainer_email='dev@formation-control.local',
    description='Backstepping formation control of vehicle fleets in a flowfield (ROS 2).',
    license='Apache-2.0',
    entry_points={
        'console_scripts': [
            'formation-control = formation_control.cli:main',
            'plant = formation_control.ros.plant:main',
            'vehicle = formation_control.ros.vehicle:main',
            'vehicles = formation_control.ros.vehicle:main_many',
            'monitor = formation_control.ros.monitor:main',
        ],
    },
)
