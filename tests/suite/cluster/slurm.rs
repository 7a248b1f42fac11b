//! The shipped SLURM job files on a real one-node SLURM: installs Debian's
//! slurmctld, slurmd, slurm-client and munge when missing, starts munged,
//! slurmctld and slurmd on this host (loopback only, every file in a
//! temporary directory), submits jobs/slurm/submit.sh for a 4-shard build of
//! a real table, waits for the merge and compares its checksums with a
//! single-machine build; the daemons it started are stopped by their pids.

use crate::common;

use common::shared_tables::shared_tables;
use common::{read_manifest, repo_root, tempdir, BIN};
use std::net::TcpListener;
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

fn sh(cmd: &str) -> std::process::Output {
    Command::new("sh").args(["-c", cmd]).output().expect("run sh")
}

fn have(program: &str) -> bool {
    sh(&format!("command -v {program}")).status.success()
}

/// Installs the packages when a program is missing (root, or sudo).
fn install_slurm() {
    if ["slurmctld", "slurmd", "sbatch", "munged"].iter().all(|p| have(p)) {
        return;
    }
    let sudo = if sh("id -u").stdout.starts_with(b"0") { "" } else { "sudo " };
    let out = sh(&format!(
        "{sudo}apt-get update -qq && DEBIAN_FRONTEND=noninteractive {sudo}apt-get install -y -qq slurmctld slurmd slurm-client munge"
    ));
    assert!(out.status.success(), "installing slurm and munge failed: {}", String::from_utf8_lossy(&out.stderr));
}

/// A free TCP port on the loopback interface.
fn free_port() -> u16 {
    TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap().port()
}

/// The daemons this test started; stopped (SIGTERM, then waited for) by pid on drop.
struct Daemons(Vec<(&'static str, Child)>);

impl Drop for Daemons {
    fn drop(&mut self) {
        for (name, child) in self.0.iter_mut().rev() {
            let _ = Command::new("kill").arg(child.id().to_string()).status();
            let deadline = Instant::now() + Duration::from_secs(20);
            while child.try_wait().ok().flatten().is_none() {
                if Instant::now() > deadline {
                    eprintln!("{name} (pid {}) did not stop on SIGTERM: killing it", child.id());
                    let _ = child.kill();
                    let _ = child.wait();
                    break;
                }
                std::thread::sleep(Duration::from_millis(100));
            }
        }
    }
}

fn spawn(daemons: &mut Daemons, name: &'static str, cmd: &mut Command, log: &Path) {
    let log = std::fs::File::create(log).unwrap();
    let child =
        cmd.stdout(log.try_clone().unwrap()).stderr(log).spawn().unwrap_or_else(|e| panic!("start {name}: {e}"));
    daemons.0.push((name, child));
}

fn wait_for(what: &str, timeout: Duration, mut ready: impl FnMut() -> bool) {
    let deadline = Instant::now() + timeout;
    while !ready() {
        assert!(Instant::now() < deadline, "timed out waiting for {what}");
        std::thread::sleep(Duration::from_millis(250));
    }
}

#[test]
fn slurm_array_job_shards_and_merge_match_a_single_build() {
    if !sh("id -u").stdout.starts_with(b"0") && !sh("sudo -n true").status.success() {
        eprintln!("skipped: a one-node SLURM needs root (or passwordless sudo)");
        return;
    }
    install_slurm();
    let tmp = tempdir();
    let t = tmp.path();
    // munged and slurmd check that the socket's directory is searchable.
    sh(&format!("chmod 755 {}", t.display()));
    for d in ["state", "spool"] {
        std::fs::create_dir(t.join(d)).unwrap();
    }
    let host = String::from_utf8(sh("hostname -s").stdout).unwrap().trim().to_string();
    let cpus = std::thread::available_parallelism().map_or(1, |n| n.get());
    let socket = t.join("munge.socket");
    let conf = t.join("slurm.conf");
    let p = |name: &str| t.join(name).display().to_string();
    let text = format!(
        "ClusterName=twoscale-test\n\
         SlurmctldHost={host}(127.0.0.1)\n\
         SlurmctldPort={ctld}\n\
         SlurmdPort={slurmd}\n\
         CommunicationParameters=NoInAddrAny\n\
         AuthType=auth/munge\n\
         AuthInfo=socket={socket}\n\
         ProctrackType=proctrack/linuxproc\n\
         TaskPlugin=task/none\n\
         JobAcctGatherType=jobacct_gather/none\n\
         SelectType=select/cons_tres\n\
         SelectTypeParameters=CR_Core\n\
         SlurmUser=root\n\
         SlurmdUser=root\n\
         MpiDefault=none\n\
         ReturnToService=2\n\
         StateSaveLocation={state}\n\
         SlurmdSpoolDir={spool}\n\
         SlurmctldLogFile={ctld_log}\n\
         SlurmdLogFile={slurmd_log}\n\
         SlurmctldPidFile={ctld_pid}\n\
         SlurmdPidFile={slurmd_pid}\n\
         NodeName={host} NodeAddr=127.0.0.1 CPUs={cpus} State=UNKNOWN\n\
         PartitionName=twoscale Nodes={host} Default=YES MaxTime=INFINITE State=UP\n",
        ctld = free_port(),
        slurmd = free_port(),
        socket = socket.display(),
        state = p("state"),
        spool = p("spool"),
        ctld_log = p("slurmctld.log"),
        slurmd_log = p("slurmd.log"),
        ctld_pid = p("slurmctld.pid"),
        slurmd_pid = p("slurmd.pid"),
    );
    std::fs::write(&conf, text).unwrap();

    let mut daemons = Daemons(Vec::new());
    spawn(
        &mut daemons,
        "munged",
        Command::new("munged").args(["--foreground", "--force"]).arg(format!("--socket={}", socket.display())).args([
            format!("--pid-file={}", p("munged.pid")),
            format!("--seed-file={}", p("munged.seed")),
            format!("--log-file={}", p("munged.log")),
        ]),
        &t.join("munged.out"),
    );
    wait_for("munged's socket", Duration::from_secs(20), || socket.exists());
    spawn(
        &mut daemons,
        "slurmctld",
        Command::new("slurmctld").arg("-D").arg("-f").arg(&conf),
        &t.join("slurmctld.out"),
    );
    spawn(&mut daemons, "slurmd", Command::new("slurmd").arg("-D").arg("-f").arg(&conf), &t.join("slurmd.out"));
    let slurm = |program: &str| {
        let mut c = Command::new(program);
        c.env("SLURM_CONF", &conf);
        c
    };
    wait_for("the node to be idle", Duration::from_secs(60), || {
        let out = slurm("sinfo").args(["-h", "-o", "%T"]).output().unwrap();
        String::from_utf8_lossy(&out.stdout).trim() == "idle"
    });

    // The shipped array job (4 shards) and its merge, waited for.
    let out_dir = t.join("tables-out");
    let submit = slurm("bash")
        .arg(repo_root().join("jobs/slurm/submit.sh"))
        .args(["4", "--preset", "paper", "--table", "epd_g1"])
        .env("TWOSCALE", BIN)
        .env("TWOSCALE_OUT", &out_dir)
        .env("TWOSCALE_WAIT", "1")
        .current_dir(t)
        .stdin(Stdio::null())
        .output()
        .unwrap();
    let logs = || {
        let mut text = String::new();
        for entry in std::fs::read_dir(out_dir.join("logs")).into_iter().flatten().flatten() {
            text += &format!(
                "--- {}\n{}",
                entry.path().display(),
                std::fs::read_to_string(entry.path()).unwrap_or_default()
            );
        }
        text
    };
    assert!(
        submit.status.success(),
        "submit.sh: {}\n{}\n{}",
        String::from_utf8_lossy(&submit.stdout),
        String::from_utf8_lossy(&submit.stderr),
        logs()
    );
    for k in 0..4 {
        let log = std::fs::read_to_string(out_dir.join(format!("logs/paper-shard-{k}.log"))).unwrap();
        assert!(log.contains(&format!("twoscale shard {k}/4")), "{log}");
        assert!(out_dir.join(format!("paper/shards/epd_g1.shard-{k}-of-4.json")).exists());
    }

    // Against the single build of the shared build root.
    let merged = read_manifest(&out_dir.join("paper/epd_g1.manifest.json"));
    let reference = read_manifest(&shared_tables().join("paper/epd_g1.manifest.json"));
    assert_eq!(merged.data_checksums(), reference.data_checksums(), "{}", logs());
    assert_eq!(merged.file, reference.file);
    assert_eq!(merged.accuracy, reference.accuracy);
    assert_eq!(merged.timing["shards"]["count"], 4);
    drop(daemons);
}
