//! The integrator settings of a render: the library's resolution (`octolux_io::settings`,
//! shared with the Python module), re-exported under the CLI's old name.

pub use octolux_io::settings::*;
