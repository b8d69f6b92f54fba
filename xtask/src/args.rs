//! The tasks' flag parsing: `--name value` pairs after the task name.

/// The value after flag `name`, if the flag is given.
pub fn value<'a>(args: &'a [String], name: &str) -> Option<&'a str> {
    let i = args.iter().position(|a| a == name)?;
    args.get(i + 1).map(String::as_str)
}

/// The value after flag `name` parsed as `T`, or `default` when the flag is absent; an error
/// when the flag has no value or the value does not parse.
pub fn parsed<T: std::str::FromStr>(args: &[String], name: &str, default: T) -> Result<T, String> {
    if !args.iter().any(|a| a == name) {
        return Ok(default);
    }
    value(args, name)
        .ok_or(format!("{name} needs a value"))?
        .parse()
        .map_err(|_| format!("bad value for {name}"))
}
