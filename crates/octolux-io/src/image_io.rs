//! Image input and output.
