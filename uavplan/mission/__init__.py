"""Mission layer: items, builder (ENU waypoints -> items), file formats. Knows no optimiser."""
