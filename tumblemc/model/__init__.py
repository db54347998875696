"""One run: parameters, shapes, frames, units, the run itself, batch rows and outcomes."""
