"""The simulated skin: physics, the family of skins, scenes, the paper's protocol."""
