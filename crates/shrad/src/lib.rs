//! shrad core.
