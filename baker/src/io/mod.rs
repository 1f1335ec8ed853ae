//! Readers and writers for the files the baker touches.
