"""Layer 1: files. Schemas, loading and unit conversion (the only place), one adapter module per
external format, atomic writers and the study store. The only layer that sees paths."""
