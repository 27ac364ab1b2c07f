"""Libraries shipped inside the package, unchanged but for their imports made relative.

``mcap`` (the MCAP reader and writer, https://github.com/foxglove/mcap, MIT licence beside
it), version :data:`VENDORED` ``['mcap']``: the node records MCAP on a vessel whose Python
packages come from the OS (rosdep, apt), and no distribution that ROS 2 Jazzy or Kilted runs on
packages it. Its compression libraries (zstandard, lz4) are packaged there and declared.

To take a new release: install it (``constraints.txt``), copy its package here and make its
absolute imports of itself relative; ``test/test_vendor.py`` checks that every file is the
installed release's with only that change.
"""

__all__ = ['VENDORED']

#: vendored distribution -> its version
VENDORED = {'mcap': '1.6.0'}
