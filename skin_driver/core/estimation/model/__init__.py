"""The skin's forward model: films, force curves and taxels (shared with the simulator)."""
