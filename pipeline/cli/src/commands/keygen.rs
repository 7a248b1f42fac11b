//! `twoscale keygen`.

use super::signing::password;
use crate::flags::KeygenArgs;
use crate::glue::input_error;
use anyhow::Result;
use twoscale_generate::ship::signing::{key_paths, keygen, PASSWORD_VAR};
use twoscale_tables::signature::key_id_hex;

/// Writes NAME.key and NAME.pub (NAME ending in .key: NAME and the .pub beside it); prints their paths and
/// the key id.
pub fn run_keygen(args: &KeygenArgs) -> Result<()> {
    let pass = if args.unencrypted {
        None
    } else {
        Some(password().ok_or_else(|| {
            input_error(format!(
                "keygen: set {PASSWORD_VAR} to the password that encrypts the secret key (or give --unencrypted)"
            ))
        })?)
    };
    let public = keygen(&args.out, pass).map_err(|e| input_error(format!("keygen: {e:#}")))?;
    let (secret, public_path) = key_paths(&args.out);
    println!("{}", secret.display());
    println!("{}", public_path.display());
    println!("key id {}", key_id_hex(&public.id));
    Ok(())
}
