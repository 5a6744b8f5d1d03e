//! Reports: image error metrics against a reference ([`metrics`]) and the `caustica compare` command
//! ([`compare`]) that prints them and writes them as JSON.

pub mod compare;
pub mod metrics;
