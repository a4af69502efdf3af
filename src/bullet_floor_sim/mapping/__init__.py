"""Building a map from scans (the embedded mapper of mapping.launch, when no SLAM package is
installed) and saving it as map_saver does.

* occupancy.py: a log-odds occupancy grid updated from laser scans at known poses;
* save.py: a map as map_server's YAML + PGM, byte for byte map_saver's layout.
"""
