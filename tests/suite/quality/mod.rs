//! The quality commands run as a user runs them.

mod commands;
