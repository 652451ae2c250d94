//! The executors: each plays a rule (`crate::sched::rule`) on one kind of worker set. Local
//! threads take their own items ([`shared`]) or run the master's passes themselves
//! ([`locked_master`]); sources behind `ComputeSource` get theirs from a master thread
//! ([`master`]) or, for a worker rule, from the calling thread ([`pull`]). None of them
//! matches on a scheduler kind: they ask the rule.

pub(crate) mod locked_master;
pub mod master;
pub(crate) mod pull;
pub(crate) mod shared;
