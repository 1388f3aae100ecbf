//! Side walls of opened cracks.
