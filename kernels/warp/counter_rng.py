"""Counter-based random numbers for Warp kernels, bit-identical to the numpy reference
(`evstar_kernels.reference.particle_filter`): a normal is Φ⁻¹ (Wichura's AS241) of a uniform
made from a PCG hash of (seed, particle, step, component)."""
import warp as wp

_PCG_MUL = wp.constant(wp.uint32(747796405))
_PCG_INC = wp.constant(wp.uint32(2891336453))
_PCG_OUT = wp.constant(wp.uint32(277803737))


@wp.func
def pcg_hash(v: wp.uint32):
    b = v * _PCG_MUL + _PCG_INC
    c = ((b >> ((b >> wp.uint32(28)) + wp.uint32(4))) ^ b) * _PCG_OUT
    return (c >> wp.uint32(22)) ^ c


@wp.func
def counter_key(seed: wp.uint32, particle: wp.uint32, step: wp.uint32):
    """pcg(pcg(pcg(seed) + particle) + step)."""
    return pcg_hash(pcg_hash(pcg_hash(seed) + particle) + step)


@wp.func
def counter_uniform(key: wp.uint32, component: wp.uint32):
    h = pcg_hash(key + component)
    return (wp.float64(h) + wp.float64(0.5)) * wp.float64(2.3283064365386963e-10)


@wp.func
def horner8(r: wp.float64, c0: wp.float64, c1: wp.float64, c2: wp.float64, c3: wp.float64,
            c4: wp.float64, c5: wp.float64, c6: wp.float64, c7: wp.float64):
    acc = c0 * r + c1
    acc = acc * r + c2
    acc = acc * r + c3
    acc = acc * r + c4
    acc = acc * r + c5
    acc = acc * r + c6
    return acc * r + c7


@wp.func
def normal_icdf(p: wp.float64):
    """Φ⁻¹(p), Wichura 1988 (AS241 PPND16); same branches and term order as the reference."""
    q = p - wp.float64(0.5)
    if wp.abs(q) <= wp.float64(0.425):
        r = wp.float64(0.180625) - q * q
        num = horner8(r, wp.float64(2509.0809287301226727), wp.float64(33430.575583588128105),
                      wp.float64(67265.770927008700853), wp.float64(45921.953931549871457),
                      wp.float64(13731.693765509461125), wp.float64(1971.5909503065514427),
                      wp.float64(133.14166789178437745), wp.float64(3.387132872796366608))
        den = horner8(r, wp.float64(5226.495278852545925), wp.float64(28729.085735721942674),
                      wp.float64(39307.89580009271061), wp.float64(21213.794301586595867),
                      wp.float64(5394.1960214247511077), wp.float64(687.1870074920579083),
                      wp.float64(42.313330701600911252), wp.float64(1.0))
        return q * num / den
    tail_p = p
    if q > wp.float64(0.0):
        tail_p = wp.float64(1.0) - p
    rt = wp.sqrt(-wp.log(tail_p))
    val = wp.float64(0.0)
    if rt <= wp.float64(5.0):
        r = rt - wp.float64(1.6)
        val = horner8(r, wp.float64(7.7454501427834140764e-4), wp.float64(0.0227238449892691845833),
                      wp.float64(0.24178072517745061177), wp.float64(1.27045825245236838258),
                      wp.float64(3.64784832476320460504), wp.float64(5.7694972214606914055),
                      wp.float64(4.6303378461565452959), wp.float64(1.42343711074968357734)) / horner8(
            r, wp.float64(1.05075007164441684324e-9), wp.float64(5.475938084995344946e-4),
            wp.float64(0.0151986665636164571966), wp.float64(0.14810397642748007459),
            wp.float64(0.68976733498510000455), wp.float64(1.6763848301838038494),
            wp.float64(2.05319162663775882187), wp.float64(1.0))
    else:
        r = rt - wp.float64(5.0)
        val = horner8(r, wp.float64(2.01033439929228813265e-7), wp.float64(2.71155556874348757815e-5),
                      wp.float64(0.0012426609473880784386), wp.float64(0.026532189526576123093),
                      wp.float64(0.29656057182850489123), wp.float64(1.7848265399172913358),
                      wp.float64(5.4637849111641143699), wp.float64(6.6579046435011037772)) / horner8(
            r, wp.float64(2.04426310338993978564e-15), wp.float64(1.4215117583164458887e-7),
            wp.float64(1.8463183175100546818e-5), wp.float64(7.868691311456132591e-4),
            wp.float64(0.0148753612908506148525), wp.float64(0.13692988092273580531),
            wp.float64(0.59983220655588793769), wp.float64(1.0))
    if q < wp.float64(0.0):
        val = -val
    return val


@wp.func
def counter_normal(key: wp.uint32, component: wp.uint32):
    return normal_icdf(counter_uniform(key, component))
