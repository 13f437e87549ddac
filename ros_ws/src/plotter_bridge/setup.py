from setuptools import find_packages, setup

package_name = 'plotter_bridge'

setup(
    name=package_name,
    version='0.1.0',
    packages=find_packages(include=[package_name, package_name + '.*']),
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + package_name]),
        ('share/' + package_name, ['package.xml']),
        ('share/' + package_name + '/rviz', ['rviz/plotter.rviz']),
        ('share/' + package_name + '/launch', ['launch/plotter.launch.py']),
        ('share/' + package_name + '/config', ['config/plotter.yaml']),
    ],
    install_requires=['setuptools'],
    extras_require={'test': ['pytest']},
    zip_safe=True,
    maintainer='Plotter maintainers',
    maintainer_email='plotter@example.com',
    description='Serial bridge between ROS 2 and the plotter board, G-code streamer, mock board, CLI.',
    license='MIT',
    entry_points={
        'console_scripts': [
            'serial_bridge = plotter_bridge.nodes.serial_bridge:main',
            'gcode_streamer = plotter_bridge.nodes.gcode_streamer:main',
            'mock_board = plotter_bridge.nodes.mock_board:main',
            'plotter = plotter_bridge.cli.main:main',
        ],
    },
)
