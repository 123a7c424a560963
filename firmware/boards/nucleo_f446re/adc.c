/*
 * Sampling a row: ADC1, ADC2 and ADC3 in triple regular simultaneous mode, started together by
 * software, each converting one rank of its sequence at the same instant; column c is ADC
 * (c % 3)'s rank c / 3. DMA2 Stream0 (channel 0, ADC1's request) in multi-ADC DMA mode 1 moves
 * the half-words ADC1, ADC2, ADC3, ADC1, ... - column order - straight into the frame.
 * A sequence of R ranks writes 3R counts: up to 2 past the row's last column (SKIN_FW_ROW_SLACK).
 */
#include "nucleo.h"
#include "skin_fw/board.h"
#include "skin_fw/fault.h"
#include "skin_fw/wait.h"

#define RANKS ((SKIN_BOARD_COLS + 2u) / 3u)
#define CONVERSIONS (3u * RANKS)
_Static_assert(CONVERSIONS - SKIN_BOARD_COLS <= SKIN_FW_ROW_SLACK,
               "the last rank's extra conversions must fit the core's slack");

/* SMPx code of a sampling time in ADC cycles. */
#define SMP_CODE(cycles)                                                                       \
  ((cycles) == 3 ? 0u : (cycles) == 15 ? 1u : (cycles) == 28 ? 2u : (cycles) == 56 ? 3u :      \
   (cycles) == 84 ? 4u : (cycles) == 112 ? 5u : (cycles) == 144 ? 6u : 7u)
#define SMP SMP_CODE(SKIN_BOARD_ADC_SAMPLE_CYCLES)

/* A rank: sampling plus 12 cycles of 12-bit conversion. The bound allows four times a row's
 * conversions and 10 us for the DMA's last transfer and the microsecond clock's granularity
 * (16 x 16 at 15 cycles: 6 ranks x 27 cycles = 7.2 us, bound 39 us); it only ends a wait that
 * something broke. */
#define RANK_CYCLES (SKIN_BOARD_ADC_SAMPLE_CYCLES + 12u)
#define ROW_US ((RANKS * RANK_CYCLES * 1000000u + NUCLEO_ADC_HZ - 1u) / NUCLEO_ADC_HZ)
#define NUCLEO_ADC_ROW_BOUND_US (4u * ROW_US + 10u)

#define OVERRUNS (ADC_CSR_OVR1 | ADC_CSR_OVR2 | ADC_CSR_OVR3)

#define COLUMN_TO_CHANNEL(c, ch) [c] = (ch),
static const uint8_t column_channel[SKIN_BOARD_COLS] = {SKIN_BOARD_COLUMNS(COLUMN_TO_CHANNEL)};

/*
 * The channel of conversion slot s (ADC s % 3, rank s / 3). Slots past the last column repeat
 * that ADC's first column: a channel no other ADC converts in the same rank (the reference
 * manual forbids sampling one channel on two ADCs at once); its count lands in the slack.
 */
static uint32_t slot_channel(uint32_t s) {
  return s < SKIN_BOARD_COLS ? column_channel[s] : column_channel[s % 3u];
}

static void set_sequence(ADC_TypeDef *adc, uint32_t which) {
  uint32_t sqr[3] = {0u, 0u, 0u}; /* SQR3 ranks 1..6, SQR2 7..12, SQR1 13..16 */
  for (uint32_t rank = 0; rank < RANKS; rank++) {
    sqr[rank / 6u] |= slot_channel(3u * rank + which) << (5u * (rank % 6u));
  }
  adc->SQR3 = sqr[0];
  adc->SQR2 = sqr[1];
  adc->SQR1 = sqr[2] | ((RANKS - 1u) << ADC_SQR1_L_Pos);
  /* The same sampling time on every channel keeps the three ADCs in lock step. */
  adc->SMPR2 = SMP * 0x09249249u; /* channels 0..9, 3 bits each */
  adc->SMPR1 = SMP * 0x01249249u; /* channels 10..18 */
  adc->CR1 = ADC_CR1_SCAN;        /* 12 bits, the whole sequence per start */
  adc->CR2 = ADC_CR2_ADON;        /* right-aligned, single sequence, software start */
}

void nucleo_adc_init(void) {
  RCC->APB2ENR |= RCC_APB2ENR_ADC1EN | RCC_APB2ENR_ADC2EN | RCC_APB2ENR_ADC3EN;
  RCC->AHB1ENR |= RCC_AHB1ENR_DMA2EN;
  (void)RCC->AHB1ENR;
  for (uint32_t c = 0; c < SKIN_BOARD_COLS; c++) {
    nucleo_gpio_analog(NUCLEO_ADC_PIN(column_channel[c]));
  }

  /* ADCCLK = APB2 / 4; triple regular simultaneous (MULTI = 10110); DMA mode 1; DDS keeps the
   * requests coming for every row without re-arming (each row converts exactly NDTR items). */
  ADC123_COMMON->CCR = ADC_CCR_ADCPRE_0 | (0x16u << ADC_CCR_MULTI_Pos) | ADC_CCR_DMA_0 |
                       ADC_CCR_DDS;
  set_sequence(ADC1, 0u);
  set_sequence(ADC2, 1u);
  set_sequence(ADC3, 2u);
  board_delay_us(3u); /* tSTAB after ADON */

  DMA2_Stream0->CR = 0u;
  (void)skin_wait_bits(&DMA2_Stream0->CR, DMA_SxCR_EN, 0u, 1000u);
  DMA2_Stream0->PAR = (uint32_t)&ADC123_COMMON->CDR;
  /* Channel 0, peripheral to memory, half-words both sides, memory increments, very high
   * priority (a late read would overrun the ADC), direct mode (no FIFO). */
  DMA2_Stream0->CR = (0u << DMA_SxCR_CHSEL_Pos) | DMA_SxCR_PL_0 | DMA_SxCR_PL_1 |
                     DMA_SxCR_MSIZE_0 | DMA_SxCR_PSIZE_0 | DMA_SxCR_MINC;
  DMA2_Stream0->FCR = 0u;
}

static void stop_stream(void) {
  DMA2_Stream0->CR &= ~DMA_SxCR_EN;
  /* The stream ends its current beat first: a few bus cycles. */
  (void)skin_wait_bits(&DMA2_Stream0->CR, DMA_SxCR_EN, 0u, 1000u);
}

static void recover_overrun(void) {
  /* An overrun stops the multi-ADC DMA requests (RM0390, "ADC overrun"): stop the stream,
   * clear the ADCs' flags and re-arm the requests; the next row starts afresh. */
  stop_stream();
  ADC1->SR = 0u;
  ADC2->SR = 0u;
  ADC3->SR = 0u;
  const uint32_t ccr = ADC123_COMMON->CCR;
  ADC123_COMMON->CCR = ccr & ~ADC_CCR_DMA;
  ADC123_COMMON->CCR = ccr;
}

static void recover_timeout(void) {
  /* A conversion or a transfer that never ended: reset the three ADCs and set them up again. */
  stop_stream();
  RCC->APB2RSTR |= RCC_APB2RSTR_ADCRST;
  RCC->APB2RSTR &= ~RCC_APB2RSTR_ADCRST;
  nucleo_adc_init();
}

/* One conversion of the row into dst: true when every count came. */
static bool convert_row(uint16_t *dst) {
  DMA2->LIFCR = DMA_LIFCR_CTCIF0 | DMA_LIFCR_CHTIF0 | DMA_LIFCR_CTEIF0 | DMA_LIFCR_CDMEIF0 |
                DMA_LIFCR_CFEIF0;
  DMA2_Stream0->M0AR = (uint32_t)dst;
  DMA2_Stream0->NDTR = CONVERSIONS;
  DMA2_Stream0->CR |= DMA_SxCR_EN;
  ADC1->CR2 |= ADC_CR2_SWSTART; /* the master's start starts ADC2 and ADC3 with it */

  const skin_wait_t done =
      skin_wait_flags(&DMA2->LISR, DMA_LISR_TCIF0, DMA_LISR_TEIF0, NUCLEO_ADC_ROW_BOUND_US);
  /* A count lost to an overrun shifts the rest of the row: with one, none of it is taken. */
  if (ADC123_COMMON->CSR & OVERRUNS) {
    skin_fault_count(SKIN_FAULT_ADC_OVERRUN);
    recover_overrun();
    return false;
  }
  if (done != SKIN_WAIT_DONE) {
    skin_fault_count(SKIN_FAULT_ADC_TIMEOUT);
    recover_timeout();
    return false;
  }
  return true;
}

bool board_sample_row(uint16_t *dst, uint8_t cols) {
  (void)cols; /* the grid is fixed at compile time: cols == SKIN_BOARD_COLS */
  /* Once more after a recovered failure: a passing overrun (the DMA held up on the bus) costs
   * one row's time, not the scan; a row that fails twice is the scan's end. */
  return convert_row(dst) || convert_row(dst);
}
