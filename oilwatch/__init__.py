"""oilwatch: the co-simulation master, the scenarios and the command line."""
