"""The skin's forward model as the estimation assumes and learns it: films, curves, taxels."""
