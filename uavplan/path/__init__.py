"""Path layer: the path frame, the energy fitness, simplification, smoothing, resampling.

Works in metres in a local frame; knows nothing of files, MAVLink or optimisers.
"""
