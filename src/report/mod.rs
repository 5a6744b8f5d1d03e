//! Reports: image error metrics against a reference ([`metrics`]) and the `caustica compare` command
//! ([`compare`]) that prints them and writes them as JSON.

pub mod compare;
pub mod converge;
pub mod error_log;
pub mod metrics;
pub mod plot;
