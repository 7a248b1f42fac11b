//! Reading tables: the CLI lookup, the golden vectors in every reader, and the readers against one another.

mod golden;
mod lookup;
mod readers;
