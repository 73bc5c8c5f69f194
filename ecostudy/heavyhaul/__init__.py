"""Feature (layer 4): heavy-haul trains as coupled masses (Zhang & Zhuan): the cascade plant so far."""
