"""Output paths that are not plain files: a CSV is written atomically (a
temporary name renamed into place), but a symlink must keep pointing at its
target and a FIFO or device must stay what it is (renaming over /dev/stdout
as root would replace the device)."""
import os
import stat
import threading

SHOT = b"x0,y0,x1,y1,vx,vy\n-0.25,0,0.1,0,0.615,0.03\n"


def test_symlink_output_writes_its_target(poolreps, tmp_path):
    target = tmp_path / "real.csv"
    target.write_text("old\n")
    link = tmp_path / "link.csv"
    link.symlink_to(target)
    r = poolreps(["shoot", "-q", "-o", link], input=SHOT)
    assert r.returncode == 0, r.stderr
    assert link.is_symlink() and os.readlink(link) == str(target)
    assert target.read_text().startswith("x0,y0,x1,y1,pocket0")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["link.csv", "real.csv"]


def test_fifo_output_stays_a_fifo(poolreps, tmp_path):
    fifo = tmp_path / "out.fifo"
    os.mkfifo(fifo)
    got = []
    reader = threading.Thread(target=lambda: got.append(fifo.read_bytes()))
    reader.start()
    r = poolreps(["shoot", "-q", "-o", fifo], input=SHOT)
    reader.join(timeout=30)
    assert r.returncode == 0, r.stderr
    assert stat.S_ISFIFO(os.stat(fifo).st_mode)
    assert got and got[0].startswith(b"x0,y0,x1,y1,pocket0")


def test_directory_as_output_is_refused(poolreps, tmp_path):
    r = poolreps(["shoot", "-q", "-o", tmp_path], input=SHOT)
    assert r.returncode == 2
    assert b"is a directory" in r.stderr and r.stderr.count(b"\n") == 1
    assert list(tmp_path.iterdir()) == []
