//! A seeded mutation harness for the `imap` command's inputs: 4 000 cases, each a small
//! valid scene (OBJ, MTL, TOML, an IES and a EULUMDAT file) with one to three mutations — bytes flipped, inserted
//! (control characters, invalid UTF-8), deleted or truncated; lines swapped, duplicated or
//! dropped; numbers replaced by hostile values; hostile statements and settings inserted.
//!
//! Every case must end in bounded time with status 0 (and every output complete) or 2
//! (one or more `imap: error:` lines, no raw control bytes, no output written); never a
//! panic (101), an abort or a signal. Set IMAP_MUTATION_CASES to run more or fewer.

use std::path::Path;
use std::process::{Command, Stdio};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::{Duration, Instant};

struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
    fn pick<'a>(&mut self, v: &[&'a str]) -> &'a str {
        v[self.below(v.len())]
    }
}

const OBJ: &str = "# a floor, a lamp and a box\nmtllib s.mtl\no floor\nusemtl grey\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvn 0 0 1\nf 1/1/1 2/2/1 3/3/1 4/4/1\no lamp\nusemtl lamp\nv 0.4 0.4 1\nv 0.6 0.4 1\nv 0.6 0.6 1\nv 0.4 0.6 1\nf 5 7 6\nf -4 -1 -2\ng box\nusemtl red\nv 0.2 0.2 0\nv 0.3 0.2 0\nv 0.3 0.3 0\nv 0.2 0.3 0\nv 0.2 0.2 0.1\nv 0.3 0.2 0.1\nv 0.3 0.3 0.1\nv 0.2 0.3 0.1\nf 9 10 14 13\nf 10 11 15 14\nf 11 12 16 15\nf 12 9 13 16\nf 13 14 15 16\ns off\nusemtl glass\nf 9 11 10\n";

const MTL: &str = "newmtl grey\nKd 0.5 0.5 0.5\nKs 0.1\nNs 10\nillum 2\nnewmtl lamp\nKe 20 20 20\nnewmtl red\nKd 0.63 0.065 0.05\nd 1\nnewmtl glass\nKd 0 0 0\nNi 1.5\nd 0.1\nTf 0.9 0.9 0.9\n";

const IES: &str = "IESNA:LM-63-2002\n[TEST] mutation\nTILT=NONE\n1 -1 1 4 2 1 2 -0.1 0 0\n1 1 10\n0 30 60 90\n0 180\n500 400 200 0\n500 300 100 0\n";

const LDT: &str = "mutation\n1\n2\n4\n90\n3\n45\nr\nl\nn\nf\nd\n0\n0\n0\n100\n50\n0\n0\n0\n0\n100\n80\n1\n0\n1\n1\nLED\n1000\n3000K\n80\n10\n0\n0\n0\n0\n0\n0\n0\n0\n0\n0\n0\n90\n180\n270\n0\n45\n90\n300\n200\n0\n310\n190\n0\n320\n180\n0\n";

const TOML: &str = "unit_m = 1.0\nrecord = [\"floor\", \"box\"]\ntwo_sided = false\n[run]\nphotons = 300\ntime_s = 5\ntarget_error = 0.0\nthreads = 2\nscheduler = \"dynamic\"\nseed = 3\nprogress_interval_s = 0.1\n[[light]]\nkind = \"spot\"\nposition = [0.5, 0.5, 2]\ndirection = [0, 0, -1]\nhalf_angle_deg = 40\npower = 5\n[[light]]\nkind = \"cosine\"\nposition = [0.5, 0.5, 1.5]\ndirection = [0, 0, -1]\namount = 100\nunit = \"cd\"\nspectrum = \"3000K\"\n[[luminaire]]\nfile = \"l.ies\"\nposition = [0.3, 0.5, 1.8]\nuse_opening = true\n[[luminaire]]\nfile = \"l.ldt\"\npositions = [[0.7, 0.5, 1.8]]\nrotation_deg = 30\n[materials.red]\nspecular = 0.2\n[camera]\nposition = [0.5, -1, 1.5]\nlook_at = [0.5, 0.5, 0]\nfov_deg = 50\nwidth = 48\nheight = 40\n";

const HOSTILE_NUMBERS: &[&str] = &[
    "nan",
    "NaN",
    "inf",
    "-inf",
    "1e39",
    "1e308",
    "-1e308",
    "1e-320",
    "0",
    "-0",
    "-1",
    "99999999999999999999",
    "",
    "0x10",
    "1,5",
    "1.2.3",
    "é",
    "\u{202e}",
    "1e31",
    "3.4e38",
    "4294967296",
    "-4294967297",
    "1e300",
    "18446744073709551616",
];

const HOSTILE_OBJ_LINES: &[&str] = &[
    "f 1 2",
    "f 0 1 2",
    "f -100 1 2",
    "f 1/2/3/4 2 3",
    "f 1 1 1",
    "f a b c",
    "usemtl",
    "usemtl nowhere",
    "mtllib nofile.mtl",
    "mtllib",
    "v",
    "v 1 2",
    "vt",
    "vn 1",
    "o",
    "g",
    "l 1 2",
    "p 1",
    "f 1// 2// 3//",
    "f 1/99 2/1 3/1",
    "v 1e39 0 0",
    "v 1 2 3 4 5 6 7",
    "mtllib ../../../../etc/passwd",
    "f 2 3 4 5 6 7 8 9",
];

const HOSTILE_MTL_LINES: &[&str] = &[
    "Kd",
    "Kd 0.5",
    "Ke 10 2",
    "Ks 1 1 1",
    "Kd 2 2 2",
    "Kd -1 0 0",
    "d -1",
    "d 2",
    "Tr 5",
    "Ni 0",
    "Ni -3",
    "illum x",
    "newmtl",
    "map_Kd",
    "map_Kd -s 1 1 1",
    "map_Kd -o",
    "map_Kd nofile.png",
    "Kd spectral x.spd",
    "Kd xyz 1 1 1",
    "Tf 0 0 0",
    "Ke 1e308 1e308 1e308",
    "newmtl grey",
];

const HOSTILE_TOML: &[&str] = &[
    "threads = 100000", "unit_m = 1e-300", "unit_m = 0", "unit_m = -1", "[spectral]\nbands = 0",
    "[spectral]\nbands = 100000", "[spectral]\nbands = 7\nmin_nm = 900\nmax_nm = 100",
    "record = [\"nope\"]", "two_sided = 3", "[[light]]\nkind = \"laser\"\nposition = [0, 0, 1]\npower = 1",
    "[[light]]\nkind = \"point\"\nposition = [0, 0, 1e300]\npower = 1",
    "[[light]]\nkind = \"point\"\nposition = [0, 0, 1]\npower = [1e308, 1e308, 1e308]",
    "[[light]]\nkind = \"spot\"\nposition = [0, 0, 1]\ndirection = [0, 0, 0]\nhalf_angle_deg = 0\npower = 1",
    "[materials.grey]\ndiffuse = [0.5, 0.5]", "[materials.glass]\ndielectric = false",
    "[materials.glass]\nior = 0.5", "[materials.glass]\nsellmeier = [[1, 1, 1], [1, 1, 1]]",
    "[camera]\nposition = [0, 0, 0]\nlook_at = [0, 0, 0]", "[camera]\nwidth = 0",
    "[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\nup = [0, 0, 1]",
    "[run]\nprogress_interval_s = 1e-12", "[run]\ntime_s = 1e300", "[run]\nscheduler = \"fast\"",
    "x = 1", "[run]\nthreads = -1", "[materials.nothing]\ndiffuse = 0.1",
    "[[light]]\nkind = \"beam\"\nposition = [0, 0, 1]\ndirection = [0, 0, -1]\namount = 1\nunit = \"lx\"",
    "[[light]]\nkind = \"point\"\nposition = [0, 0, 1]\namount = 1\nunit = \"lx\"",
    "[[light]]\nkind = \"point\"\nposition = [0, 0, 1]\namount = 10\nunit = \"parsec\"",
    "[[light]]\nkind = \"point\"\nposition = [0, 0, 1]\namount = 10\nunit = \"lm\"\nspectrum = \"-5K\"",
    "[[light]]\nkind = \"point\"\nposition = [0, 0, 1]\namount = 10\nunit = \"lm\"\nspectrum_table = [[400, 0], [500, 0]]",
    "[[luminaire]]\nfile = \"nofile.ies\"\nposition = [0, 0, 1]",
    "[[luminaire]]\nfile = \"l.ies\"",
    "[[luminaire]]\nfile = \"l.ies\"\nposition = [0, 0, 1]\naim = [0, 0, 0]",
    "[[luminaire]]\nfile = \"l.ies\"\nposition = [0, 0, 1]\naim = [1, 0, 0]\nreference = [2, 0, 0]",
    "[[luminaire]]\nfile = \"l.ldt\"\narray = { start = [0, 0, 1], count = [1000000, 1000000], step_a = [1, 0, 0] }",
    "[[luminaire]]\nfile = \"l.ldt\"\narray = { start = [0, 0, 1], count = [30, 30], step_a = [0.01, 0, 0], step_b = [0, 0.01, 0] }",
    "[[luminaire]]\nfile = \"s.obj\"\nposition = [0, 0, 1]",
    "[[luminaire]]\nfile = \"l.ies\"\nposition = [0, 0, 1]\nflux_scale = -1",
    "[[luminaire]]\nfile = \"l.ies\"\nposition = [0, 0, 1]\nlumens = 1e308",
];

fn mutate_bytes(rng: &mut Rng, text: &mut Vec<u8>) {
    if text.is_empty() {
        return;
    }
    let at = rng.below(text.len());
    match rng.below(5) {
        0 => text[at] ^= 1 << rng.below(8),
        1 => {
            let junk: &[&[u8]] = &[
                b"\x00",
                b"\x1b[2J",
                b"\xff\xfe",
                b"\r",
                b"\x07",
                b"\\\n",
                b"\t\t",
                b"\xc3",
            ];
            let j = junk[rng.below(junk.len())];
            text.splice(at..at, j.iter().copied());
        }
        2 => {
            let end = (at + 1 + rng.below(20)).min(text.len());
            text.drain(at..end);
        }
        3 => text.truncate(at),
        _ => {
            let end = (at + rng.below(8)).min(text.len());
            let copy: Vec<u8> = text[at..end].to_vec();
            text.splice(at..at, copy);
        }
    }
}

fn mutate_lines(rng: &mut Rng, text: &mut Vec<u8>, statements: &[&str]) {
    let s = String::from_utf8_lossy(text).into_owned();
    let mut lines: Vec<String> = s.lines().map(str::to_string).collect();
    if lines.is_empty() {
        lines.push(String::new());
    }
    let n = lines.len();
    match rng.below(6) {
        0 => {
            let (a, b) = (rng.below(n), rng.below(n));
            lines.swap(a, b);
        }
        1 => {
            let a = rng.below(n);
            lines.insert(a, lines[a].clone());
        }
        2 => {
            lines.remove(rng.below(n));
        }
        3 => {
            // A number replaced by a hostile one.
            let a = rng.below(n);
            let mut words: Vec<String> = lines[a].split(' ').map(str::to_string).collect();
            let nums: Vec<usize> = (0..words.len())
                .filter(|&i| words[i].parse::<f64>().is_ok() || words[i].contains('/'))
                .collect();
            if !nums.is_empty() {
                let i = nums[rng.below(nums.len())];
                words[i] = rng.pick(HOSTILE_NUMBERS).to_string();
                lines[a] = words.join(" ");
            }
        }
        4 => {
            let a = rng.below(n + 1);
            lines.insert(a, rng.pick(statements).to_string());
        }
        _ => {
            let a = rng.below(n);
            lines[a] = "9".repeat(1 + rng.below(100_000));
        }
    }
    *text = lines.join("\n").into_bytes();
    text.push(b'\n');
}

/// One case: the files, mutated; returns a description of a failure, if any.
fn case(seed: u64, dir: &Path) -> Result<(), String> {
    let mut rng = Rng(seed);
    let mut files = [
        OBJ.as_bytes().to_vec(),
        MTL.as_bytes().to_vec(),
        TOML.as_bytes().to_vec(),
        IES.as_bytes().to_vec(),
        LDT.as_bytes().to_vec(),
    ];
    for _ in 0..1 + rng.below(3) {
        let f = rng.below(5);
        match (f, rng.below(3)) {
            (_, 0) => mutate_bytes(&mut rng, &mut files[f]),
            (0, _) => mutate_lines(&mut rng, &mut files[0], HOSTILE_OBJ_LINES),
            (1, _) => mutate_lines(&mut rng, &mut files[1], HOSTILE_MTL_LINES),
            (3 | 4, _) => mutate_lines(&mut rng, &mut files[f], HOSTILE_NUMBERS),
            _ => {
                if rng.below(2) == 0 {
                    let extra = format!("\n{}\n", rng.pick(HOSTILE_TOML));
                    files[2].extend(extra.as_bytes());
                } else {
                    mutate_lines(&mut rng, &mut files[2], HOSTILE_NUMBERS);
                }
            }
        }
    }
    std::fs::create_dir_all(dir).unwrap();
    for (name, bytes) in ["s.obj", "s.mtl", "s.toml", "l.ies", "l.ldt"]
        .iter()
        .zip(&files)
    {
        std::fs::write(dir.join(name), bytes).unwrap();
    }
    let out = dir.join("out");
    let _ = std::fs::remove_dir_all(&out);
    let t = Instant::now();
    let mut child = Command::new(env!("CARGO_BIN_EXE_imap"))
        .arg("run")
        .arg(dir.join("s.obj"))
        .arg("--config")
        .arg(dir.join("s.toml"))
        .args(["--photons", "300", "--time", "5", "--quiet", "--out"])
        .arg(&out)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        if t.elapsed() > Duration::from_secs(60) {
            let _ = child.kill();
            return Err(format!("seed {seed}: no exit within 60 s"));
        }
        std::thread::sleep(Duration::from_millis(5));
    };
    let mut err = Vec::new();
    use std::io::Read;
    child.stderr.take().unwrap().read_to_end(&mut err).unwrap();
    let err_text = String::from_utf8_lossy(&err).into_owned();
    let outputs: Vec<String> = std::fs::read_dir(&out)
        .map(|r| {
            r.map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
                .collect()
        })
        .unwrap_or_default();
    match status.code() {
        Some(0) => {
            let mut o = outputs.clone();
            o.sort();
            if o != [
                "convergence.png",
                "irradiance.csv",
                "irradiance.ply",
                "report.json",
                "view.png",
            ] {
                return Err(format!("seed {seed}: succeeded with outputs {o:?}"));
            }
            let report = std::fs::read_to_string(out.join("report.json")).unwrap();
            serde_json::from_str::<serde_json::Value>(&report)
                .map_err(|e| format!("seed {seed}: report.json: {e}"))?;
        }
        Some(2) => {
            let errors: Vec<&str> = err_text
                .lines()
                .filter(|l| l.starts_with("imap: error:"))
                .collect();
            if errors.is_empty() || errors.iter().any(|l| l.len() <= "imap: error: ".len()) {
                return Err(format!(
                    "seed {seed}: exit 2 without an error message: {err_text}"
                ));
            }
            if !outputs.is_empty() {
                return Err(format!(
                    "seed {seed}: failed but left outputs {outputs:?}: {err_text}"
                ));
            }
        }
        other => {
            return Err(format!(
                "seed {seed}: exit {other:?} (a panic or a signal): {err_text}"
            ))
        }
    }
    if err.iter().any(|&b| b < 0x20 && b != b'\n') {
        return Err(format!(
            "seed {seed}: raw control bytes on stderr: {err_text:?}"
        ));
    }
    Ok(())
}

#[test]
fn mutated_inputs_end_in_a_status_never_a_crash() {
    let cases: u64 = std::env::var("IMAP_MUTATION_CASES")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(4000);
    let root = tempfile::tempdir().unwrap();
    let next = AtomicUsize::new(0);
    let failures = Mutex::new(Vec::new());
    let (ok, err) = (AtomicUsize::new(0), AtomicUsize::new(0));
    let workers = std::thread::available_parallelism()
        .map_or(2, |n| n.get())
        .min(8);
    let t = Instant::now();
    std::thread::scope(|s| {
        for w in 0..workers {
            let (root, next, failures, ok, err) = (&root, &next, &failures, &ok, &err);
            s.spawn(move || {
                let dir = root.path().join(format!("w{w}"));
                loop {
                    let i = next.fetch_add(1, Ordering::Relaxed) as u64;
                    if i >= cases {
                        break;
                    }
                    match case(1000 + i, &dir) {
                        Ok(()) => {
                            let code_ok = dir.join("out").join("report.json").exists();
                            if code_ok { ok } else { err }.fetch_add(1, Ordering::Relaxed);
                        }
                        Err(e) => failures.lock().unwrap().push(e),
                    }
                }
            });
        }
    });
    let failures = failures.into_inner().unwrap();
    eprintln!(
        "{cases} mutated inputs in {:.0} s: {} ran, {} were refused with a message, {} misbehaved",
        t.elapsed().as_secs_f64(),
        ok.load(Ordering::Relaxed),
        err.load(Ordering::Relaxed),
        failures.len()
    );
    for f in failures.iter().take(10) {
        eprintln!("  {f}");
    }
    assert!(failures.is_empty());
}
