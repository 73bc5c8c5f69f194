"""Feature (layer 4): heavy-haul trains as coupled masses (paper 002): the cascade plant so far."""
