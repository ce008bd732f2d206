"""stepramp.verify: chip-rule checks, simulation, comparison and the CLI."""
