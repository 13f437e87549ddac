from setuptools import setup

package_name = 'plotter_shapes'

setup(
    name=package_name,
    version='0.1.0',
    packages=[package_name],
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + package_name]),
        ('share/' + package_name, ['package.xml']),
    ],
    install_requires=['setuptools'],
    extras_require={'test': ['pytest']},
    zip_safe=True,
    maintainer='Plotter maintainers',
    maintainer_email='plotter@example.com',
    description='Shape geometry, SVG and text input, the DrawShape action server and the draw, '
                'svg and text subcommands of the plotter command.',
    license='MIT',
    entry_points={
        'console_scripts': [
            'shape_server = plotter_shapes.shape_server_node:main',
        ],
        # Subcommands of plotter_bridge's `plotter` command (draw, svg, text).
        'plotter.commands': [
            'shapes = plotter_shapes.commands:COMMANDS',
        ],
        # Sheets of lines for `plotter follow`, by file suffix: an SVG placed as `plotter svg` places it.
        'plotter.sheets': [
            'svg = plotter_shapes.svg_input:sheet_lines',
        ],
    },
)
