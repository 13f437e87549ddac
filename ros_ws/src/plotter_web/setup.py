from setuptools import setup

package_name = 'plotter_web'

setup(
    name=package_name,
    version='0.1.0',
    packages=[package_name],
    package_data={package_name: ['static/*']},
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + package_name]),
        ('share/' + package_name, ['package.xml']),
    ],
    install_requires=['setuptools'],
    extras_require={'test': ['pytest']},
    zip_safe=False,
    maintainer='Plotter maintainers',
    maintainer_email='plotter@example.com',
    description='A web page for the pen plotter, served by the web_ui node.',
    license='MIT',
    entry_points={
        'console_scripts': [
            'web_ui = plotter_web.web_ui_node:main',
        ],
    },
)
