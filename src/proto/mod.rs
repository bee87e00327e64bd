//! Sans-I/O protocol state machines.
