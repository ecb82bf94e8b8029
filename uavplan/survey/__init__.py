"""Area surveys: camera arithmetic, lanes around holes, the sweep of least energy.

Pure geometry in local ENU metres (numpy + shapely) over the vocabulary layer: no files, no
MAVLink, no world. The wiring layer checks transitions against the world and builds missions.
"""
