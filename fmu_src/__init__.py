"""FMI 2.0 co-simulation slaves (pythonfmu). Nothing outside this folder imports pythonfmu."""
